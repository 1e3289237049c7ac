"""The C export as a component: prefixed API, strict flags, statuses, saturation, float build, against numpy.

Each exported step is compiled with the system C compiler and driven through its
API; the reference is the numpy controller (:meth:`DiscreteLaw.step`, matrices and
closed-form output stage), a route independent of the CasADi code generation.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nniquad.certificates.c_export import STATUSES, c_file_names
from nniquad.certificates.certificate import read_certificate
from nniquad.certificates.export import controller_from_certificate, export_controller, export_prefix
from nniquad.config import EXPORT_POSITION_ERROR_LIMIT_M
from nniquad.control.inner_loops import G_Z_MIN_FRACTION
from nniquad.control.references import FigureEight
from nniquad.sim import SimOptions, simulate

DATA = Path(__file__).resolve().parents[1] / "notebooks" / "data"
#: Two committed certificates of two laws (NNI, 2 states; sni2, 4 states).
CERTS = {"nni": DATA / "full_model_certificate.json", "sni2": DATA / "sni2_cascade_certificate.json"}
CC = shutil.which("gcc") or shutil.which("cc")
CXX = shutil.which("g++")
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wmissing-prototypes"]
STATUS = {name: value for name, value, _ in STATUSES}
#: Largest difference of the single-precision build's tilt setpoints from the double build's [rad], over a
#: recorded 3 s run of each law (docs/export.md states it; measured 2.1e-6 NNI, 3.5e-6 sni2): float's 2^-24
#: relative precision times the conditioning of the step (the state integrates the error).
FLOAT_TILT_BOUND_RAD = 2e-5

pytestmark = pytest.mark.skipif(CC is None, reason="needs a C compiler")

#: A driver of one export: one command a line (i init, r reset, s start, t step; then position, setpoint, yaw, a_z,
#: the feedforward),
#: printing the status, whether the state and the outputs stayed byte-identical, the state and the outputs.
DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "PFX.h"
int main(void) {
    PFX_state s;
    PFX_input in;
    PFX_output out;
    char line[512], op;
    int i, st = 0;
    memset(&s, 0, sizeof s);
    memset(&out, 0, sizeof out);
    while (fgets(line, sizeof line, stdin)) {
        double v[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        char *p = line + 1;
        PFX_state s0 = s;
        PFX_output o0 = out;
        op = line[0];
        for (i = 0; i < 8; ++i) v[i] = strtod(p, &p);
        in.position_m[0] = (PFX_real)v[0]; in.position_m[1] = (PFX_real)v[1];
        in.setpoint_m[0] = (PFX_real)v[2]; in.setpoint_m[1] = (PFX_real)v[3];
        in.yaw_rad = (PFX_real)v[4]; in.a_z_m_s2 = (PFX_real)v[5];
        in.accel_ff_m_s2[0] = (PFX_real)v[6]; in.accel_ff_m_s2[1] = (PFX_real)v[7];
        if (op == 'i') st = PFX_init(&s);
        else if (op == 'r') st = PFX_reset(&s);
        else if (op == 's') st = PFX_start(&s, &in);
        else st = PFX_step(&s, &in, &out);
        printf("%d %d", st, memcmp(&s0, &s, sizeof s) == 0 && memcmp(&o0, &out, sizeof out) == 0);
        for (i = 0; i < PFX_UPPER_STATE_SIZE; ++i) printf(" %.17g", (double)s.z[i]);
        printf(" %.17g %.17g %.17g %.17g %.17g\n", (double)out.tilt_rad[0], (double)out.tilt_rad[1],
               (double)out.a_h_m_s2[0], (double)out.a_h_m_s2[1], (double)out.g_z_m_s2);
    }
    return 0;
}
"""


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    """Both certificates exported (default prefixes) into one folder: {law: (prefix, certificate)}."""
    d = tmp_path_factory.mktemp("c_export")
    out = {}
    for law, path in CERTS.items():
        cert = read_certificate(path)
        export_controller(cert, d, "c")
        out[law] = (export_prefix(cert), cert)
    return d, out


def _compile(d: Path, prefix: str, *flags: str) -> Path:
    src = d / f"driver_{prefix}{'_'.join(flags).replace('-', '')}.c"
    src.write_text(DRIVER.replace("PFX_UPPER", prefix.upper()).replace("PFX", prefix))
    exe = src.with_suffix("")
    subprocess.run([CC, *STRICT, "-O2", *flags, "-I", str(d), "-o", str(exe), str(src), str(d / f"{prefix}.c"), "-lm"],
                   check=True, capture_output=True, text=True)
    return exe


def _drive(exe: Path, lines: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(status, unchanged flag, numbers) per command."""
    text = subprocess.run([str(exe)], input="\n".join(lines) + "\n", capture_output=True, text=True,
                          check=True).stdout
    rows = np.array([[float(v) for v in r.split()] for r in text.splitlines()])
    return rows[:, 0].astype(int), rows[:, 1].astype(bool), rows[:, 2:]


def _cmd(op: str, pos, ref, psi: float, a_z: float, ff=(0.0, 0.0)) -> str:
    return f"{op} {pos[0]:.17g} {pos[1]:.17g} {ref[0]:.17g} {ref[1]:.17g} {psi:.17g} {a_z:.17g} {ff[0]:.17g} {ff[1]:.17g}"


def _recorded_run(cert, law: str):
    """A reduced-model run at 100 Hz from the certificate's start, with a setpoint, yaw and altitude command."""
    tr = simulate(cert.vehicle, cert.gains, SimOptions(model="reduced", horizon_s=3.0, output_dt_s=0.01,
                                                       sample_hold=True))[0]
    rng = np.random.default_rng(len(law))
    ref = np.array([3.25, -1.5])
    return tr.xy + ref, ref, rng.uniform(-math.pi, math.pi, len(tr.xy)), rng.uniform(-3.0, 3.0, len(tr.xy))


def _reference(ctrl, xi, psi, a_z, z0=None, a_ff=None):
    run = ctrl.run(xi, psi, a_z, z0=z0, a_ff=a_ff)
    g_z = np.array([max(ctrl.g - a, G_Z_MIN_FRACTION * ctrl.g) for a in a_z])  # the clamp as the docs state it
    return np.column_stack([run["z"][1:], run["tilt_sp"], run["a_h"], g_z])


@pytest.mark.parametrize("law", sorted(CERTS))
def test_c_step_equals_the_numpy_controller_over_a_run(exports, law):
    d, ex = exports
    prefix, cert = ex[law]
    ctrl = controller_from_certificate(cert, 100.0)
    pos, ref, psi, a_z = _recorded_run(cert, law)
    lines = ["i", _cmd("s", pos[0], ref, 0.0, 0.0)] + [_cmd("t", p, ref, s, a) for p, s, a in zip(pos, psi, a_z)]
    status, _, got = _drive(_compile(d, prefix), lines)
    assert np.all(status == STATUS["OK"])
    want = _reference(ctrl, pos - ref, psi, a_z)
    scale = np.maximum(1.0, np.max(np.abs(want), axis=0))
    assert np.max(np.abs(got[2:] - want) / scale) < 1e-12
    np.testing.assert_allclose(got[1, :ctrl.n_state], ctrl.start(pos[0] - ref), rtol=0, atol=1e-12)


@pytest.mark.parametrize("law", sorted(CERTS))
def test_c_step_with_a_moving_setpoint_and_feedforward_equals_the_numpy_controller(exports, law):
    """The figure-eight as the setpoint and its acceleration as the feedforward, sampled at 100 Hz, over a
    reduced-model run that follows it: the C step against :meth:`DiscreteLaw.step` with ``a_ff``."""
    d, ex = exports
    prefix, cert = ex[law]
    ctrl = controller_from_certificate(cert, 100.0)
    eight = FigureEight(2.0, 1.0, 8.0)
    p0, v0, _ = eight.sample(0.0)
    o = SimOptions(model="reduced", horizon_s=3.0, output_dt_s=0.01, controller_sampling="discrete",
                   reference=eight, feedforward=True, xi0=tuple(p0[0] + [0.3, -0.2]), v0=tuple(v0[0]))
    tr = simulate(cert.vehicle, cert.gains, o)[0]
    ref, _, ff = eight.sample(tr.t)
    rng = np.random.default_rng(7)
    psi, a_z = rng.uniform(-math.pi, math.pi, len(tr.t)), rng.uniform(-3.0, 3.0, len(tr.t))
    pos = tr.xy
    lines = ["i", _cmd("s", pos[0], ref[0], 0.0, 0.0)] + [_cmd("t", *row) for row in zip(pos, ref, psi, a_z, ff)]
    status, _, got = _drive(_compile(d, prefix), lines)
    assert np.all(status == STATUS["OK"])
    want = _reference(ctrl, pos - ref, psi, a_z, a_ff=ff)
    scale = np.maximum(1.0, np.max(np.abs(want), axis=0))
    assert np.max(np.abs(got[2:] - want) / scale) < 1e-12
    # the feedforward is really in the command: without it the numpy controller differs
    assert np.max(np.abs(_reference(ctrl, pos - ref, psi, a_z) - want)) > 0.1


def test_two_exports_link_into_one_program_and_both_step(exports):
    d, ex = exports
    (p1, c1), (p2, c2) = ex["nni"], ex["sni2"]
    main = d / "both.c"
    main.write_text(f"""
#include <stdio.h>
#include "{p1}.h"
#include "{p2}.h"
int main(void) {{
    {p1}_state s1; {p1}_input i1 = {{{{1.0, -0.5}}, {{0.0, 0.0}}, 0.3, 0.0, {{0.0, 0.0}}}}; {p1}_output o1;
    {p2}_state s2; {p2}_input i2 = {{{{1.0, -0.5}}, {{0.0, 0.0}}, 0.3, 0.0, {{0.0, 0.0}}}}; {p2}_output o2;
    if ({p1}_init(&s1) || {p1}_start(&s1, &i1) || {p1}_step(&s1, &i1, &o1)) return 1;
    if ({p2}_init(&s2) || {p2}_start(&s2, &i2) || {p2}_step(&s2, &i2, &o2)) return 2;
    printf("%.17g %.17g %.17g %.17g\\n", o1.tilt_rad[0], o1.tilt_rad[1], o2.tilt_rad[0], o2.tilt_rad[1]);
    return 0;
}}
""")
    objs = []
    for p in (p1, p2):
        obj = d / f"{p}.o"
        subprocess.run([CC, *STRICT, "-c", "-o", str(obj), str(d / f"{p}.c")], check=True, capture_output=True)
        objs.append(obj)
        # the public symbols: the four API functions, each with the prefix; nothing else global
        nm = shutil.which("nm")
        if nm:
            listing = subprocess.run([nm, "-g", "--defined-only", str(obj)], capture_output=True, text=True,
                                     check=True).stdout
            defined = sorted(line.split()[-1] for line in listing.splitlines() if line.strip())
            assert defined == sorted(f"{p}_{f}" for f in ("init", "reset", "start", "step"))
    exe = d / "both"
    subprocess.run([CC, *STRICT, "-I", str(d), "-o", str(exe), str(main), *map(str, objs), "-lm"], check=True,
                   capture_output=True)
    got = np.array(subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split(), float)
    xi = np.array([[1.0, -0.5]])
    for k, cert in enumerate((c1, c2)):
        ctrl = controller_from_certificate(cert, 100.0)
        np.testing.assert_allclose(got[2 * k:2 * k + 2], ctrl.run(xi, np.array([0.3]))["tilt_sp"][0], atol=1e-12)


@pytest.mark.parametrize("law", sorted(CERTS))
def test_export_compiles_clean_as_c99_cxx_and_single_precision(exports, law):
    d, ex = exports
    prefix, _ = ex[law]
    c_name, h_name = c_file_names(prefix)
    P = prefix.upper()
    src = str(d / c_name)
    runs = [[CC, *STRICT, "-c", src, "-o", str(d / f"{prefix}_c.o")],
            [CC, *STRICT, "-Wdouble-promotion", f"-D{P}_USE_FLOAT", "-c", src, "-o", str(d / f"{prefix}_f.o")]]
    if CXX:
        runs.append([CXX, "-x", "c++", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c", src, "-o",
                     str(d / f"{prefix}_cxx.o")])
    for argv in runs:
        r = subprocess.run(argv, capture_output=True, text=True)
        assert r.returncode == 0 and not r.stderr, (argv, r.stderr)
    header = (d / h_name).read_text()
    source = (d / c_name).read_text()
    assert "casadi" not in header and f'#include "{h_name}"' in source
    assert f"#define {P}_STATE_SIZE {controller_from_certificate(ex[law][1], 100.0).n_state}\n" in header
    assert f"#ifndef {P}_STATE_SIZE" not in header
    for name in ("RATE_HZ", "PERIOD_S", "CERTIFICATE_DIGEST", "TILT_LIMIT_RAD", "MASS_NOMINAL_KG", "GRAVITY_M_S2",
                 "ATTITUDE_WN_RAD_S", "ATTITUDE_ZETA", "ATTITUDE_LAG_S", "BOX_MASS_FACTOR_MIN"):
        assert f"#define {P}_{name} " in header, name
    # the delay the certificate covers, read from the file itself (these predate the field: none)
    stated = json.loads(Path(CERTS[law]).read_text()).get("delay_samples", 0)
    assert f"#define {P}_CERTIFIED_DELAY_SAMPLES {stated}\n" in header


@pytest.mark.parametrize("law", sorted(CERTS))
def test_non_finite_input_is_refused_and_leaves_the_state_bit_identical(exports, law):
    d, ex = exports
    prefix, cert = ex[law]
    ref = [0.5, -0.25]
    bad = [_cmd("t", [v, 0.0], ref, 0.1, 0.0) for v in (math.nan, math.inf)]
    bad += [_cmd("t", [0.0, 0.0], ref, math.nan, 0.0), _cmd("t", [0.0, 0.0], ref, 0.0, -math.inf),
            _cmd("t", [0.0, 0.0], [math.nan, 0.0], 0.0, 0.0), _cmd("t", [1.7e308, 0.0], [-1.7e308, 0.0], 0.0, 0.0)]
    lines = ["i", _cmd("t", [1.0, 1.0], ref, 0.0, 0.0), _cmd("s", [math.nan, 0.0], ref, 0.0, 0.0),
             _cmd("s", [1.0, 1.0], ref, 0.0, 0.0), _cmd("t", [1.0, 1.0], ref, 0.2, 0.5), *bad,
             _cmd("t", [1.2, 0.9], ref, 0.2, 0.5)]
    status, same, got = _drive(_compile(d, prefix), lines)
    assert status[1] == STATUS["ERR_NOT_STARTED"] and same[1]          # step before start
    assert status[2] == STATUS["ERR_NOT_FINITE"] and same[2]           # start on a NaN
    assert list(status[5:-1]) == [STATUS["ERR_NOT_FINITE"]] * len(bad)  # incl. position - setpoint overflowing
    assert np.all(same[5:-1]) and not same[4]                          # byte for byte as before
    ctrl = controller_from_certificate(cert, 100.0)
    xi = np.array([[1.0, 1.0], [1.2, 0.9]]) - ref
    want = _reference(ctrl, xi, np.array([0.2, 0.2]), np.array([0.5, 0.5]))
    np.testing.assert_allclose(got[-1], want[-1], rtol=1e-12, atol=1e-12)  # the NaNs were never seen


@pytest.mark.parametrize("law", sorted(CERTS))
def test_huge_finite_input_saturates_with_its_direction_and_the_state_recovers(exports, law):
    d, ex = exports
    prefix, cert = ex[law]
    ctrl = controller_from_certificate(cert, 100.0)
    glitch = np.array([3e300, -4e300])
    n = 300
    xi = np.vstack([[0.04, 0.01], glitch, np.tile([0.04, 0.01], (n, 1))])
    lines = ["i", _cmd("s", xi[0], [0, 0], 0.0, 0.0)] + [_cmd("t", x, [0, 0], 0.0, 0.0) for x in xi]
    status, _, got = _drive(_compile(d, prefix), lines)
    assert np.all(status[1:] == STATUS["OK"])
    # the contract: the law sees the error scaled down to the limit, direction kept (numpy's hypot, exact scaling)
    clamped = xi.copy()
    clamped[1] = (glitch / 1e300) / np.hypot(*(glitch / 1e300)) * EXPORT_POSITION_ERROR_LIMIT_M
    want = _reference(ctrl, clamped, np.zeros(len(xi)), np.zeros(len(xi)))
    ns = ctrl.n_state
    scale = np.maximum(1.0, np.max(np.abs(want), axis=0))
    assert np.max(np.abs(got[2:] - want) / scale) < 1e-12
    tilt = got[3, ns:ns + 2]
    a_h = got[3, ns + 2:ns + 4]
    assert np.hypot(*a_h) == pytest.approx(ctrl.g * math.tan(ctrl.tilt_limit_rad), rel=1e-12)  # at the limit
    assert np.all(np.abs(got[2:, ns:ns + 2]) <= ctrl.tilt_limit_rad + 1e-12) and np.all(np.isfinite(tilt))
    bound = np.abs(ctrl.A) @ np.abs(got[2, :ns]) + np.abs(ctrl.B) @ np.full(2, EXPORT_POSITION_ERROR_LIMIT_M)
    assert np.all(np.abs(got[3, :ns]) <= bound)  # the state moved by one limited sample, not by 1e300
    if law == "nni":  # the command points against the error, and leaves the limit well within the run (3 s)
        assert np.dot(a_h, glitch / np.linalg.norm(glitch / 1e300)) < 0
        assert np.hypot(*got[-1, ns + 2:ns + 4]) < 0.99 * np.hypot(*a_h)


@pytest.mark.parametrize("law", sorted(CERTS))
def test_single_precision_build_within_its_stated_bound(exports, law):
    d, ex = exports
    prefix, cert = ex[law]
    pos, ref, psi, a_z = _recorded_run(cert, law)
    lines = ["i", _cmd("s", pos[0], ref, 0.0, 0.0)] + [_cmd("t", p, ref, s, a) for p, s, a in zip(pos, psi, a_z)]
    ns = controller_from_certificate(cert, 100.0).n_state
    _, _, dbl = _drive(_compile(d, prefix), lines)
    st, _, flt = _drive(_compile(d, prefix, "-Wdouble-promotion", f"-D{prefix.upper()}_USE_FLOAT"), lines)
    assert np.all(st == STATUS["OK"])
    err = np.max(np.abs(flt[2:, ns:ns + 2] - dbl[2:, ns:ns + 2]))
    assert 0 < err < FLOAT_TILT_BOUND_RAD  # nonzero: the float build is really single precision


@pytest.mark.parametrize("law", sorted(CERTS))
def test_start_is_bumpless_and_reset_needs_a_new_start(exports, law):
    d, ex = exports
    prefix, cert = ex[law]
    ctrl = controller_from_certificate(cert, 100.0)
    pos, ref = np.array([2.0, -1.0]), np.array([0.5, 0.5])
    lines = ["i", _cmd("s", pos, ref, 0.0, 0.0), _cmd("t", pos, ref, 0.0, 0.0), _cmd("t", pos, ref, 0.0, 0.0),
             "r", _cmd("t", pos, ref, 0.0, 0.0), _cmd("s", pos, ref, 0.0, 0.0), _cmd("t", pos, ref, 0.0, 0.0)]
    status, same, got = _drive(_compile(d, prefix), lines)
    assert list(status) == [STATUS["OK"]] * 5 + [STATUS["ERR_NOT_STARTED"], STATUS["OK"], STATUS["OK"]]
    ns = ctrl.n_state
    z0 = got[1, :ns]
    np.testing.assert_allclose(z0, ctrl.start(pos - ref), rtol=0, atol=1e-12)
    if ctrl.S is not None:  # sni2: taken over at rest, the state does not move at a constant error
        np.testing.assert_allclose(got[2, :ns], z0, rtol=1e-12, atol=1e-12 * np.max(np.abs(z0)))
        assert np.max(np.abs(z0)) > 1.0
    np.testing.assert_array_equal(got[4, :ns], 0.0)          # reset: state as init leaves it
    np.testing.assert_array_equal(got[7], got[2])             # after a new start, as the first time
    assert same[5]


def test_prefix_option_names_the_files_and_bad_prefix_is_one_line(tmp_path, run_cli):
    code, out, err = run_cli("export", str(CERTS["nni"]), "--format", "c", "--prefix", "quad_a", "--out", str(tmp_path))
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["quad_a.c", "quad_a.h"]
    assert "int quad_a_step(quad_a_state *state, const quad_a_input *in, quad_a_output *out);" in \
        (tmp_path / "quad_a.h").read_text()
    code, out, err = run_cli("export", str(CERTS["nni"]), "--format", "c", "--prefix", "9bad-name",
                             "--out", str(tmp_path / "o"))
    assert code == 2 and "prefix must be a C identifier" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_integral_law_c_step_with_anti_windup_equals_the_numpy_controller(tmp_path):
    """The ``sni2_i`` law (the sni2 certificate's design with the seeded integral gain) exported and driven from a
    2.5 m start, saturated for its first steps, with a changing yaw and altitude command (the C step computes the
    excess from its own tilt limit ``g_z tan``): the C step against :meth:`DiscreteLaw.step` with its anti-windup."""
    import dataclasses

    from nniquad.certificates.c_export import write_c
    from nniquad.control.discrete import DiscreteLaw
    from nniquad.laws import integral_variant

    cert = read_certificate(CERTS["sni2"])  # the header's vehicle and inner loop; the gains are the integral law's
    gains = integral_variant(cert.gains.law).seed_from(cert.gains, cert.vehicle.m)
    ctrl = DiscreteLaw.from_gains(gains, cert.vehicle.m, cert.vehicle.g, 100.0, cert.tilt_limit_deg)
    assert ctrl.W is not None
    write_c(ctrl, cert, tmp_path, "integ", rate_certified=False)
    tr = simulate(cert.vehicle, gains, SimOptions(model="reduced", horizon_s=3.0, output_dt_s=0.01, xi0=(2.5, -0.5),
                                                  controller_sampling="discrete"))[0]
    rng = np.random.default_rng(44)
    ref = np.array([1.0, 2.0])
    pos, psi, a_z = tr.xy + ref, rng.uniform(-math.pi, math.pi, len(tr.t)), rng.uniform(-3.0, 3.0, len(tr.t))
    lines = ["i", _cmd("s", pos[0], ref, 0.0, 0.0)] + [_cmd("t", p, ref, s, a) for p, s, a in zip(pos, psi, a_z)]
    status, _, got = _drive(_compile(tmp_path, "integ"), lines)
    assert np.all(status == STATUS["OK"])
    want = _reference(ctrl, pos - ref, psi, a_z)
    scale = np.maximum(1.0, np.max(np.abs(want), axis=0))
    assert np.max(np.abs(got[2:] - want) / scale) < 1e-12
    ns = ctrl.n_state
    g_z = want[:, ns + 4]
    saturated = np.hypot(want[:, ns + 2], want[:, ns + 3]) >= g_z * math.tan(ctrl.tilt_limit_rad) * (1 - 1e-12)
    assert saturated[:5].all() and not saturated[-10:].any()
    # the anti-windup is in the C step: without it the integrator states differ after the saturated steps
    plain = _reference(dataclasses.replace(ctrl, W=None), pos - ref, psi, a_z)
    assert np.max(np.abs(plain[:, ns - 2:ns] - got[2:, ns - 2:ns])) > 1e-3
