"""``nniquad export``: the generated C step, compiled with gcc, against the numpy controller."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nniquad.analysis.sampled import nni_zoh_closed_form
from nniquad.certificates.certificate import certificate_gains, certificate_vehicle, load_certificate, \
    read_certificate
from nniquad.certificates.export import controller_from_certificate, export_controller
from nniquad.errors import ExportError, NniquadError
from nniquad.sim import SimOptions, simulate

CERT = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"

def test_json_export_states_the_exact_discretisation(tmp_path, run_cli):
    code, _, err = run_cli("export", str(CERT), "--format", "json", "--out", str(tmp_path), "--rate", "250")
    assert code == 0, err
    doc = json.loads((tmp_path / "nniquad_controller.json").read_text())
    g = certificate_gains(load_certificate(CERT))
    a, b = nni_zoh_closed_form(g.Gamma, g.delta, 1 / 250)
    np.testing.assert_allclose(doc["A"], a * np.eye(2), rtol=1e-15)
    np.testing.assert_allclose(doc["B"], b * np.eye(2), rtol=1e-15)
    np.testing.assert_allclose(doc["D"], -g.kp * np.eye(2), rtol=1e-15)
    assert doc["rate_hz"] == 250 and doc["units"]["B"] == "N/m"
    assert doc["sampled_cascade"]["stable"] and doc["sampled_cascade"]["spectral_radius"] < 1
    inner, cert = doc["inner_loop_assumed"], load_certificate(CERT)  # the attitude loop the certificate needs
    il = cert["inner_loop"]
    assert inner["attitude_lag_s"] == pytest.approx(2 * il["attitude_zeta"] / il["attitude_wn_rad_s"], rel=1e-15)
    assert inner["certified_box"] == cert["cascade"]["box"]


@pytest.mark.parametrize("args, message", [
    (["--rate", "0"], "rate must be a finite positive"),
    (["--rate", "nan"], "rate must be a finite positive"),
    (["--out", "/proc/nniquad-cannot"], "cannot write"),  # refused by main's output check, before any work
])
def test_bad_input_gets_one_line(tmp_path, run_cli, args, message):
    argv = ["export", str(CERT), "--out", str(tmp_path / "o"), *args]
    code, out, err = run_cli(*argv)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o" / "nniquad_controller.json").exists()


def test_bad_certificate_gets_one_line(tmp_path, run_cli):
    bad = tmp_path / "bad.json"
    text = CERT.read_text()
    kp = json.loads(text)["gains"]["kp"]
    tampered = text.replace(f'"kp": {kp!r}', f'"kp": {kp + 1.0!r}', 1)  # the signed gain changed, digest kept
    assert tampered != text
    bad.write_text(tampered)
    code, _, err = run_cli("export", str(bad), "--out", str(tmp_path / "o"))
    # exit-status scheme (nniquad.cli.main): a digest mismatch is a failed check, 1
    assert code == 1 and "digest mismatch" in err and len(err.strip().splitlines()) == 1


def test_typed_and_mapping_certificates_give_one_controller():
    typed, mapping = read_certificate(CERT), load_certificate(CERT)
    a, b = controller_from_certificate(typed, 100.0), controller_from_certificate(mapping, 100.0)
    for name in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.tilt_limit_rad == b.tilt_limit_rad == math.radians(mapping["tilt_limit_deg"])


def test_export_errors_are_project_errors(tmp_path):
    assert issubclass(ExportError, NniquadError)
    with pytest.raises(ExportError, match="unknown format"):
        export_controller(read_certificate(CERT), tmp_path, fmt="rust")
    assert not any(tmp_path.iterdir())


#: The docs page that shows a flight stack's position task calling the exported step (its C block is compiled here).
EXPORT_DOC = Path(__file__).resolve().parents[1] / "docs" / "export.md"

#: The prefix the docs' C block is written for.
DOC_PREFIX = "quad_nni"

README_MAIN = r"""
#include <stdio.h>
void position_task(const double pos_ned_m[2], const double sp_ned_m[2], double yaw_rad, double a_z_m_s2,
                   double tilt_sp_rad[2]);
int main(void) {
    double xi[2], psi, a_z, tilt[2];
    const double setpoint[2] = {0.0, 0.0};
    while (scanf("%lf %lf %lf %lf", &xi[0], &xi[1], &psi, &a_z) == 4) {
        position_task(xi, setpoint, psi, a_z, tilt);
        printf("%.17g %.17g\n", tilt[0], tilt[1]);
    }
    return 0;
}
"""


def _readme_c_block() -> str:
    import re

    section = EXPORT_DOC.read_text(encoding="utf-8").split("### Flying the exported controller", 1)[1]
    m = re.search(r"```c\n(.*?)```", section, flags=re.S)
    assert m, "docs/export.md has no C block under 'Flying the exported controller'"
    return m.group(1)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs the system C compiler")
def test_readme_flight_stack_snippet_compiles_and_flies_the_python_controller(tmp_path, run_cli):
    """The docs' C position task (docs/export.md), compiled as written, gives the Python controller's tilt set points."""
    code, out, err = run_cli("export", str(CERT), "--format", "c", "--prefix", DOC_PREFIX, "--out", str(tmp_path))
    assert code == 0, err
    (tmp_path / "task.c").write_text(_readme_c_block())
    (tmp_path / "main.c").write_text(README_MAIN)
    exe = tmp_path / "task"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Werror", "-O2", "-o", str(exe), str(tmp_path / "main.c"),
                    str(tmp_path / "task.c"), str(tmp_path / f"{DOC_PREFIX}.c"), "-lm"],
                   check=True, capture_output=True, cwd=tmp_path)
    cert = load_certificate(CERT)
    tr = simulate(certificate_vehicle(cert), certificate_gains(cert),
                  SimOptions(model="reduced", horizon_s=2.0, output_dt_s=0.01, sample_hold=True))[0]
    rng = np.random.default_rng(5)
    psi, a_z = rng.uniform(-1.0, 1.0, len(tr.xy)), rng.uniform(-2.0, 2.0, len(tr.xy))
    text = "\n".join(f"{a:.17g} {b:.17g} {c:.17g} {d:.17g}" for (a, b), c, d in zip(tr.xy, psi, a_z)) + "\n"
    got = np.loadtxt(subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True)
                     .stdout.splitlines())
    ref = controller_from_certificate(cert, 100.0).run(tr.xy, psi, a_z)
    np.testing.assert_allclose(got, ref["tilt_sp"], rtol=0, atol=1e-12)
    assert np.ptp(got[:, 0]) > 0.1  # the set points move: a stuck state would not match anyway
