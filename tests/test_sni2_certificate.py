"""Certificates, ``verify``, Monte Carlo and ``nniquad export`` of the ``sni2`` law.

The references: the certificate's own numbers recomputed by ``verify`` (which must also refuse re-signed edits of
the law and of its controller matrices), the NNI law's certificate of the same vehicle (another law: its numbers
must not verify the ``sni2`` document), ``scipy.linalg.expm`` for the exported matrices, and gcc-compiled C stepped
against the Python controller.
"""

from __future__ import annotations

import copy
import json
import shutil
import subprocess

import numpy as np
import pytest

from nniquad.analysis.sampled import zoh
from nniquad.certificates import (Certificate, build_certificate, canonical_digest, certificate_gains,
                                  verify_certificate, write_certificate)
from nniquad.certificates.export import controller_from_certificate
from nniquad.scenarios.ranges import DEFAULT_RANGES
from nniquad.laws.sni2 import SNI2Gains
from nniquad.laws.sni2 import controller_matrices, sni2_from_nni
from nniquad.errors import CertificateError, NniquadError
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.sim import SimOptions, simulate
from tests.test_certificate import GAINS, INNER, SMALL_BOX
from tests.test_export import DOC_PREFIX, README_MAIN, _readme_c_block

#: The test design of test_certificate in the sni2 law: the NNI law behind a low-pass 34 times faster than its pole
#: (sni2_from_nni at zeta = 3), DC loop gain 0.799 (paper class); it certifies over SMALL_BOX.
SNI2_GAINS = SNI2Gains(*sni2_from_nni(GAINS.kp, GAINS.Gamma, GAINS.delta, 3.0))

#: One xdist worker runs this module: its certificate is built once, and a second worker never sits waiting for it.
pytestmark = pytest.mark.xdist_group("sni2_certificate")


def build_sni2_certificate() -> dict:
    return build_certificate(V, SNI2_GAINS, inner=INNER, model="full", box=SMALL_BOX).to_json()


@pytest.fixture(scope="module")
def doc(shared_json) -> dict:
    return shared_json("sni2-small-certificate", build_sni2_certificate)


def _resign(c: dict) -> dict:
    c["digest"]["value"] = canonical_digest(c)
    return c


def _refused(c: dict) -> bool:
    try:
        return not verify_certificate(_resign(c), fail_fast=True).ok
    except NniquadError:
        return True


def test_certificate_states_the_law_and_verifies(doc, tmp_path):
    assert doc["gains"] == {"controller": "sni2", **SNI2_GAINS.values()}
    assert set(doc["sector"]) == {"gamma", "gamma_max", "k_max"}
    assert np.asarray(doc["lmi"]["controller_ni"]["P"]).shape == (2, 2)
    assert np.asarray(doc["lmi"]["closed_loop"]["P"]).shape == (4, 4)
    assert "zcd_x" in doc["cascade"]["lyapunov"]["subsystems"]["x"]["states"]
    cert = Certificate.from_json(doc)
    assert cert.controller == "sni2" and certificate_gains(doc) == SNI2_GAINS
    res = verify_certificate(write_certificate(doc, tmp_path / "c.json"))
    assert res.ok, res.table()
    # the stored storage is the controller's energy, diag(omega^2, 1)/k (hand derivation, test_sni2)
    g = SNI2_GAINS
    np.testing.assert_allclose(doc["lmi"]["controller_ni"]["P"], np.diag([g.omega**2, 1.0]) / g.k, rtol=1e-6,
                               atol=1e-6 * g.omega**2 / g.k)
    # the reduced region of attraction holds the law's take-over state r (1, 0, C(0), 0)
    r = doc["region_of_attraction"]["max_displacement_m"]
    P = np.asarray(doc["lmi"]["region_of_attraction"]["P"])
    v = r * np.array([1.0, 0.0, g.k / g.omega**2, 0.0])
    assert v @ P @ v <= 1 + 1e-6 and (1.01 * v) @ P @ (1.01 * v) > 1.0


def test_schema_1_certificate_of_the_law_verifies():
    cert = build_certificate(V, SNI2_GAINS, inner=INNER, model="full", cascade=False)
    assert cert.schema_version == 1 and cert.controller == "sni2"
    res = verify_certificate(cert)
    assert res.ok, res.table()


@pytest.mark.parametrize("edit", [
    ("gains", "zeta", 1.001), ("gains", "zeta", -1.0), ("gains", "k", 1.001), ("gains", "omega", 1.001),
    ("gains", "kp", 1.001), ("sector", "k_max", 1.001), ("sector", "gamma", 1.001)])
def test_resigned_edit_of_a_gain_or_the_dc_condition_is_refused(doc, edit):
    section, key, factor = edit
    c = copy.deepcopy(doc)
    c[section][key] *= factor
    assert _refused(c)


@pytest.mark.parametrize("i, j", [(0, 0), (1, 1), (0, 1)])
def test_resigned_edit_of_the_controller_storage_is_refused(doc, i, j):
    """A stored NI storage entry moved by 1 %: the NI lemma re-check (P > 0, dissipation <= tol) refuses it."""
    c = copy.deepcopy(doc)
    P = np.asarray(c["lmi"]["controller_ni"]["P"])
    delta = 1e-2 * max(abs(P[i, j]), abs(P[0, 0]) * 1e-3)
    c["lmi"]["controller_ni"]["P"][i][j] += delta
    if i != j:
        c["lmi"]["controller_ni"]["P"][j][i] += delta
    assert _refused(c)


@pytest.mark.parametrize("edit", ["nni law", "no law", "unknown law", "extra gain"])
def test_resigned_edit_of_the_law_is_refused(doc, edit):
    """The law named in the gains section is part of the signed statement: another law, none, an unknown one or
    an extra gain is refused (one line), never read as a certificate of something else."""
    c = copy.deepcopy(doc)
    if edit == "nni law":
        c["gains"] = {"kp": GAINS.kp, "Gamma": GAINS.Gamma, "delta": GAINS.delta}  # a valid NNI gain set
    elif edit == "no law":
        del c["gains"]["controller"]
    elif edit == "unknown law":
        c["gains"]["controller"] = "sni3"
    else:
        c["gains"]["Gamma"] = 1.0
    assert _refused(c)
    if edit != "nni law":
        with pytest.raises(CertificateError):
            Certificate.from_json(_resign(c))


def test_the_study_draws_the_scenarios_of_a_certificate_as_of_its_setup(doc):
    """``nniquad.study.draw_scenarios`` takes a loaded certificate (the study layer reads it) and draws exactly the
    scenarios the scenarios layer draws from that certificate's setup."""
    import nniquad.study as mc
    from nniquad.scenarios.draws import draw_scenarios as draw_from_setup

    setup = mc.study_setup(doc)
    assert mc.draw_scenarios(4, 9, cert=doc) == draw_from_setup(4, 9, mc.DEFAULT_RANGES, setup)
    assert mc.draw_scenarios(4, 9, cert=setup) == mc.draw_scenarios(4, 9, cert=doc)


def test_monte_carlo_runs_the_certified_law(doc):
    """The study of an sni2 certificate simulates the sni2 law in discrete time from its take-over state."""
    from nniquad.jobs.montecarlo import montecarlo
    from nniquad.study.certificate_setup import study_setup

    setup = study_setup(doc)
    assert setup.controller == "sni2" and setup.controller_sampling == "discrete"
    assert setup.base.gains == SNI2_GAINS
    # in still air: the base law has no integral action, so under the default wind it settles off the setpoint
    still = DEFAULT_RANGES.with_(wind_weight_fraction=(0.0, 0.0))
    res = montecarlo(doc, samples=4, seed=5, workers=1, ranges=still)
    assert res.summary.n == 4 and res.summary.n_success == 4


def test_json_export_states_the_exact_discretisation(doc, tmp_path, run_cli):
    path = write_certificate(doc, tmp_path / "c.json")
    code, _, err = run_cli("export", str(path), "--format", "json", "--out", str(tmp_path), "--rate", "250")
    assert code == 0, err
    out = json.loads((tmp_path / "nniquad_controller.json").read_text())
    g = SNI2_GAINS
    A_c, B_c, _, _ = controller_matrices(g.k, g.omega, g.zeta)
    Ad, Bd = zoh(A_c, B_c, 1 / 250)  # scipy expm of the per-axis controller
    A, B = np.asarray(out["A"]), np.asarray(out["B"])
    for axis in (0, 1):  # state order (z_x, z_y, z'_x, z'_y)
        idx = [axis, 2 + axis]
        np.testing.assert_allclose(A[np.ix_(idx, idx)], Ad, rtol=1e-14)
        np.testing.assert_allclose(B[idx, axis], Bd[:, 0], rtol=1e-14)
    assert out["law"] == "sni2" and out["state_names"] == ["z_x", "z_y", "zdot_x", "zdot_y"]
    assert out["step_inputs"][0]["size"] == 4 and out["sampled_cascade"]["stable"]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs the system C compiler")
def test_readme_flight_stack_snippet_flies_the_sni2_controller(doc, tmp_path, run_cli):
    """The docs' C position task (docs/export.md), compiled as written against an sni2 export, gives the Python controller's
    tilt set points from its take-over state (the export's start), to 1e-12."""
    path = write_certificate(doc, tmp_path / "c.json")
    code, _, err = run_cli("export", str(path), "--format", "c", "--prefix", DOC_PREFIX, "--out", str(tmp_path))
    assert code == 0, err
    header = (tmp_path / f"{DOC_PREFIX}.h").read_text()
    assert f"#define {DOC_PREFIX.upper()}_STATE_SIZE 4\n" in header
    (tmp_path / "task.c").write_text(_readme_c_block())
    (tmp_path / "main.c").write_text(README_MAIN)
    exe = tmp_path / "task"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Werror", "-O2", "-o", str(exe), str(tmp_path / "main.c"),
                    str(tmp_path / "task.c"), str(tmp_path / f"{DOC_PREFIX}.c"), "-lm"],
                   check=True, capture_output=True, cwd=tmp_path)
    tr = simulate(V, SNI2_GAINS, SimOptions(model="reduced", horizon_s=2.0, output_dt_s=0.01, sample_hold=True))[0]
    rng = np.random.default_rng(5)
    psi, a_z = rng.uniform(-1.0, 1.0, len(tr.xy)), rng.uniform(-2.0, 2.0, len(tr.xy))
    text = "\n".join(f"{a:.17g} {b:.17g} {c:.17g} {d:.17g}" for (a, b), c, d in zip(tr.xy, psi, a_z)) + "\n"
    got = np.loadtxt(subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True)
                     .stdout.splitlines())
    ctrl = controller_from_certificate(doc, 100.0)
    ref = ctrl.run(tr.xy, psi, a_z)  # from ctrl.start(first sample), as the task does
    np.testing.assert_allclose(got, ref["tilt_sp"], rtol=0, atol=1e-12)
    # started at zero instead, the first set points differ: the take-over state is exercised
    zero = ctrl.run(tr.xy, psi, a_z, z0=np.zeros(4))
    assert np.max(np.abs(zero["tilt_sp"][:5] - ref["tilt_sp"][:5])) > 1e-3
