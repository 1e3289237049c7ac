"""A certificate's reference run flown again: ``simulate --certificate``, ``Certificate.run_settings`` and
``nniquad.simulate_certificate`` on a certificate of a vehicle other than the paper's.

The certificate is ``tests/data/iris_certificate.json`` (the 1.5 kg Iris, made by the command in
tests/data/README.md).  What the runs are compared with is the certificate's own record, written when it was
certified: the numbers ``performance.full`` states, and the vehicle, inner loops and rate its fields state
(never the code that reads the run back).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import nniquad as nq
from nniquad.certificates.certificate import TOLERANCES
from nniquad.errors import EXIT_CHECK_FAILED

DATA = Path(__file__).resolve().parent / "data"
CERT_PATH = DATA / "iris_certificate.json"
PAPER_TOML = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "vehicles"
#: Each stated number of a reference run and the tolerance it is re-simulated within (as verify checks it).
WITHIN = {"settling_s": TOLERANCES["settling_abs_s"], "overshoot_pct": TOLERANCES["overshoot_abs_pct"],
          "peak_tilt_deg": TOLERANCES["tilt_abs_deg"]}


@pytest.fixture(scope="module")
def cert() -> nq.Certificate:
    c = nq.read_certificate(CERT_PATH)
    assert c.vehicle != nq.PAPER_VEHICLE and c.vehicle.m != nq.PAPER_VEHICLE.m  # the point of the test
    return c


def assert_reproduces(stated, got) -> None:
    for key, tol in WITHIN.items():
        assert got[key] == pytest.approx(stated[key], abs=tol), key
    assert got["diverged"] is stated["diverged"] is False


def test_simulate_certificate_flies_the_certificates_vehicle_and_reproduces_performance_full(run_cli, tmp_path,
                                                                                             cert):
    js = tmp_path / "run.json"
    code, out, err = run_cli("simulate", "--certificate", str(CERT_PATH), "--json", str(js))
    assert code == 0, err
    data = json.loads(js.read_text())
    # the certificate's vehicle, inner loops, rate and motor lag, as its own fields state them
    assert data["vehicle"] == cert.vehicle.as_dict() and f"vehicle: {cert.vehicle.name}" in out
    opts = data["options"]
    assert opts["inner"] == cert.inner_loop.as_dict()
    assert opts["controller_sampling"] == "discrete" and opts["noise_rate_hz"] == cert.cascade["rate_hz"]
    assert opts["motor_lag"] is True and opts["xi0"] == list(cert.xi0_m)
    assert opts["tilt_limit_deg"] == cert.tilt_limit_deg
    # ... and every recorded setting of the reference run
    assert opts == cert.to_json()["performance"]["full"]["settings"]
    assert_reproduces(cert.performance["full"], data)
    assert data["certificate"]["reproduced"] is True and data["certificate"]["overridden"] == []
    assert "reproduces performance.full: yes" in out
    # every digit the certificate states is printed beside the re-simulated value
    assert repr(cert.performance["full"]["settling_s"]) in out


def test_python_api_flies_the_same_run(cert):
    run = cert.run_settings()
    assert run.vehicle == cert.vehicle and run.gains == cert.gains and run.inner == cert.inner_loop
    assert run.options.motor_lag and run.options.sampling == "discrete"
    met = nq.simulate_certificate(CERT_PATH)[0].metrics()
    assert_reproduces(cert.performance["full"], {k: getattr(met, k) for k in (*WITHIN, "diverged")})
    # the same run through nq.simulate, and the reduced reference run as well
    again = nq.simulate(**run.kwargs())[0].metrics()
    assert again.settling_s == met.settling_s
    red = cert.run_settings("reduced")
    assert red.options.model == "reduced" and not red.options.motor_lag
    met_r = red.simulate()[0].metrics()
    assert_reproduces(cert.performance["reduced"], {k: getattr(met_r, k) for k in (*WITHIN, "diverged")})


def test_overrides_are_named_and_nothing_is_compared(run_cli, tmp_path):
    js = tmp_path / "o.json"
    code, out, err = run_cli("simulate", "--certificate", str(CERT_PATH), "--rate", "50", "--no-motor-lag",
                             "--horizon", "5", "--json", str(js))
    assert code == 0, err
    data = json.loads(js.read_text())
    assert data["certificate"]["overridden"] == ["--horizon", "--motor-lag", "--rate"]
    assert data["certificate"]["reproduced"] is None and data["options"]["noise_rate_hz"] == 50.0
    assert "--horizon, --motor-lag, --rate overridden: not the certificate's run" in out
    assert "reproduces" not in out
    # an option given with the certificate's own value overrides nothing
    code, out, err = run_cli("simulate", "--certificate", str(CERT_PATH), "--rate", "100", "--motor-lag",
                             "--horizon", "20")
    assert code == 0 and "overridden" not in out and "reproduces performance.full: yes" in out


def test_another_vehicle_is_an_override(run_cli, tmp_path, cert):
    """The Iris's gains flown on the Crazyflie (what `simulate --certificate` did before, with the paper's
    vehicle): named as an override, and the run is not the certificate's."""
    js = tmp_path / "v.json"
    code, out, err = run_cli("simulate", "--certificate", str(CERT_PATH), "--vehicle",
                             str(PAPER_TOML / "crazyflie2.toml"), "--horizon", "3", "--json", str(js))
    assert code == 0, err
    data = json.loads(js.read_text())
    assert data["certificate"]["overridden"][0] == "--vehicle" and data["vehicle"]["m"] != cert.vehicle.m


def test_a_run_that_does_not_reproduce_its_statement_exits_1(run_cli, tmp_path, cert):
    """A certificate re-signed with a settling time 0.1 s off its run: the re-simulation says so and exits 1."""
    from dataclasses import replace

    perf = json.loads(json.dumps(cert.to_json()["performance"]))
    perf["full"]["settling_s"] += 0.1
    bad = replace(cert, performance=perf).signed()
    path = bad.write(tmp_path / "bad.json")
    code, out, err = run_cli("simulate", "--certificate", str(path))
    assert code == EXIT_CHECK_FAILED
    assert "reproduces performance.full: NO: settling_s differ" in out
