"""``montecarlo --within-certificate``: scenarios only inside a certificate's cascade box and region.

The certificate is the committed full-model certificate (schema 1) with a
hand-made ``cascade`` section, re-signed; the drawn plants are checked against
the box from the simulator's own parameter vectors (true plant / nominal
vehicle), not from the factors the draw records.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

import nniquad.study as mc
from nniquad.certificates.certificate import canonical_digest, certificate_vehicle
from nniquad.errors import MonteCarloError

ROOT = Path(__file__).resolve().parents[1]
CERT = ROOT / "notebooks" / "data" / "full_model_certificate.json"
BOX = {"mass_factor": [0.9, 1.1], "inertia_factor": [0.85, 1.15], "attitude_gain_factor": [0.9, 1.2],
       "tau_motor_factor": [0.75, 1.5]}
REGION_M = 1.2
RATE_HZ = 50.0


def _with_cascade(box=BOX, region=REGION_M, rate=RATE_HZ) -> dict:
    cert = json.loads(CERT.read_text())
    cert["cascade"] = {"rate_hz": rate, "controller": "discrete", "attitude_loop": "continuous",
                       "box": copy.deepcopy(box), "region_of_attraction": {"max_displacement_m": region}}
    return cert


def _signed_file(tmp_path, cert: dict) -> Path:
    cert = {k: v for k, v in cert.items() if k != "digest"}
    cert["schema_version"] = 2  # a cascade section makes a schema-2 certificate
    cert["digest"] = {"algorithm": "sha256", "value": canonical_digest(cert)}
    path = tmp_path / "cascade_cert.json"
    path.write_text(json.dumps(cert))
    return path


def _inside(lo_hi, value, tol=1e-12):
    lo, hi = lo_hi
    return lo * (1 - tol) <= value <= hi * (1 + tol)


def test_ranges_are_the_box_region_and_rate_without_noise_or_wind():
    ranges, region, rate = mc.within_certificate_ranges(_with_cascade())
    for key in mc.BOX_KEYS:
        assert list(getattr(ranges, key)) == BOX[key]
    assert region == REGION_M and rate == RATE_HZ and ranges.noise_rate_hz == RATE_HZ
    assert ranges.noise_sigma_m == (0.0, 0.0) and ranges.wind_weight_fraction == (0.0, 0.0) and ranges.wind_N is None
    assert ranges.tau_motor_s is None and ranges.max_displacement_m == REGION_M


def test_every_drawn_scenario_lies_inside_the_box_and_region():
    cert = _with_cascade()
    ranges, region, _ = mc.within_certificate_ranges(cert)
    setup = mc.study_setup(cert, ranges, region_m=region, horizon_s=6.0)
    assert setup.region_m == REGION_M and setup.controller_sampling == "discrete"
    nominal = certificate_vehicle(cert)
    scenarios = mc.draw_scenarios(200, 3, ranges, setup)
    cols = {k: [] for k in ("m", "Jx", "Jy", "Jz", "att", "tau", "r")}
    for s in scenarios:
        p = s.sim_params
        cols["m"].append(p.plant.m / nominal.m)
        for axis in ("Jx", "Jy", "Jz"):
            cols[axis].append(getattr(p.plant, axis) / getattr(nominal, axis))
        cols["att"].append(p.inner.attitude_gain_scale / setup.base.inner.attitude_gain_scale)
        cols["tau"].append(p.plant.tau_motor / nominal.tau_motor)
        cols["r"].append(math.hypot(*s.xi0_m))
        assert s.noise_sigma_m == 0.0 and p.run.wind_x == 0.0 and p.run.wind_y == 0.0
        assert p.run.discrete == 1.0 and p.run.sample_period == pytest.approx(1 / RATE_HZ)
        assert s.noise_rate_hz == RATE_HZ and s.controller_sampling == "discrete"
        # the nominal (controller) side is never perturbed
        assert p.nominal.m == nominal.m and p.nominal.Jx == nominal.Jx
    for name, key in (("m", "mass_factor"), ("Jx", "inertia_factor"), ("Jy", "inertia_factor"),
                      ("Jz", "inertia_factor"), ("att", "attitude_gain_factor"), ("tau", "tau_motor_factor")):
        v = np.array(cols[name])
        assert all(_inside(BOX[key], x) for x in v), name
        lo, hi = BOX[key]
        assert v.min() < lo + 0.1 * (hi - lo) and v.max() > hi - 0.1 * (hi - lo), name  # the whole box is drawn
    r = np.array(cols["r"])
    # a tenth of the starts on the rim of the certified disk (MC_WITHIN_RIM_FRACTION): at the radius, to the
    # rounding of R cos, R sin (the certified region's inclusion margin is orders of magnitude wider)
    assert r.max() <= REGION_M * (1 + 4 * np.finfo(float).eps) and r.max() > 0.9 * REGION_M
    from nniquad.config import MC_WITHIN_RIM_FRACTION

    on_rim = np.isclose(r, REGION_M, rtol=1e-12, atol=0)
    assert abs(on_rim.mean() - MC_WITHIN_RIM_FRACTION) < 0.1, on_rim.mean()


def test_a_narrow_box_leaves_no_draw_outside_it():
    box = {"mass_factor": [1.05, 1.06], "inertia_factor": [1.0, 1.0], "attitude_gain_factor": [0.95, 0.96],
           "tau_motor_factor": [1.2, 1.25]}
    cert = _with_cascade(box=box, region=0.3)
    ranges, region, _ = mc.within_certificate_ranges(cert)
    setup = mc.study_setup(cert, ranges, region_m=region)
    nominal = certificate_vehicle(cert)
    for s in mc.draw_scenarios(50, 0, ranges, setup):
        p = s.sim_params
        assert _inside(box["mass_factor"], p.plant.m / nominal.m)
        assert p.plant.Jx == pytest.approx(nominal.Jx, rel=1e-15) and p.plant.Jz == pytest.approx(nominal.Jz, rel=1e-15)
        assert _inside(box["tau_motor_factor"], p.plant.tau_motor / nominal.tau_motor)
        assert math.hypot(*s.xi0_m) <= 0.3


def test_small_study_inside_the_box_converges():
    from nniquad.jobs.montecarlo import montecarlo

    res = montecarlo(_with_cascade(), 6, 0, within_certificate=True, horizon_s=6.0, workers=1)
    assert res.run.n_requested == 6 and len(res.run.results) == 6
    assert all(r.success for r in res.run.results), [(r.index, r.failure) for r in res.run.results]
    assert res.setup.to_json()["rate_hz"] == RATE_HZ and res.ranges.noise_sigma_m == (0.0, 0.0)
    with pytest.raises(MonteCarloError, match="ranges from the certificate"):
        montecarlo(_with_cascade(), 2, 0, within_certificate=True, ranges=mc.ScenarioRanges(), workers=1)


@pytest.mark.parametrize("change, message", [
    (lambda c: c.pop("cascade"), "certifies no parameter box"),
    (lambda c: c["cascade"].pop("box"), "no 'box'"),
    (lambda c: c["cascade"]["box"].pop("tau_motor_factor"), "lacks 'tau_motor_factor'"),
    (lambda c: c["cascade"]["box"].update(mass_factor=[1.2, 0.8]), "above high"),
    (lambda c: c["cascade"]["box"].update(inertia_factor=[0.0, 1.0]), "positive"),
    (lambda c: c["cascade"]["region_of_attraction"].pop("max_displacement_m"), "max_displacement_m"),
    (lambda c: c["cascade"].update(rate_hz=float("nan")), "rate_hz"),
])
def test_certificates_that_certify_no_usable_box(change, message):
    cert = _with_cascade()
    change(cert)
    with pytest.raises(MonteCarloError, match=message):
        mc.within_certificate_ranges(cert)


def test_certificate_rate():
    cert = _with_cascade(rate=200.0)
    assert mc.certificate_rate_hz(cert) == 200.0
    cert.pop("cascade")
    assert mc.certificate_rate_hz(cert) == cert["margins"]["rate_hz"]
    cert.pop("margins")
    from nniquad.config import CONTROL_RATE_HZ

    assert mc.certificate_rate_hz(cert) == CONTROL_RATE_HZ


# ------------------------------------------------------------------------------ CLI


def test_cli_within_certificate_all_converge(run_cli, tmp_path):
    path = _signed_file(tmp_path, _with_cascade())
    code, out, err = run_cli("montecarlo", "--certificate", str(path), "--within-certificate", "--samples", "4",
                             "--horizon", "6", "--workers", "1")
    assert code == 0, err
    assert "within certificate: 4/4 converged" in out and "FAILED" not in out


def test_cli_within_certificate_failures_exit_1_and_rerun(run_cli, tmp_path):
    # a box the vehicle cannot fly (thrust-to-weight about 2: 2.3 x the mass falls): every scenario fails
    box = {**BOX, "mass_factor": [2.3, 2.4]}
    path = _signed_file(tmp_path, _with_cascade(box=box))
    code, out, err = run_cli("montecarlo", "--certificate", str(path), "--within-certificate", "--samples", "2",
                             "--horizon", "3", "--workers", "1")
    assert code == 1, (out, err)
    assert "within certificate: 0/2 converged" in out
    lines = [ln for ln in out.splitlines() if ln.startswith("FAILED within certificate")]
    assert len(lines) == 2
    for i, line in enumerate(lines):
        assert f"scenario {i} (altitude lost)" in line
        cmd = line.split("rerun: ", 1)[1].split()
        assert cmd[:2] == ["nniquad", "montecarlo"] and "--within-certificate" in cmd and cmd[-1] == str(i)
        code2, out2, err2 = run_cli(*cmd[1:])
        assert code2 == 1 and f"scenario {i} of seed 0: FAILURE: altitude lost" in out2, (out2, err2)


@pytest.mark.parametrize("extra, message", [
    (["--mass-range", "0.9", "1.1"], "drop --mass-range"),
    (["--rate", "100"], "drop --rate"),
])
def test_cli_within_certificate_takes_nothing_else(run_cli, tmp_path, extra, message):
    path = _signed_file(tmp_path, _with_cascade())
    code, out, err = run_cli("montecarlo", "--certificate", str(path), "--within-certificate", "--samples", "2", *extra)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err


def test_cli_within_certificate_without_cascade_section(run_cli):
    schema1 = Path(__file__).resolve().parent / "data" / "schema1_certificate.json"
    code, out, err = run_cli("montecarlo", "--certificate", str(schema1), "--within-certificate", "--samples", "2")
    assert code == 2, (out, err)
    assert "certifies no parameter box" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("args, rate", [([], 100.0), (["--rate", "50"], 50.0)])
def test_cli_rate_reaches_the_study(run_cli, tmp_path, args, rate):
    js = tmp_path / "mc.json"
    code, out, err = run_cli("montecarlo", "--certificate", str(CERT), "--samples", "1", "--horizon", "0.5",
                             "--workers", "1", "--json", str(js), *args)
    assert code == 0, err
    setup = json.loads(js.read_text())["study"]["setup"]
    assert setup["rate_hz"] == rate and setup["controller_sampling"] == "discrete"
    assert json.loads(js.read_text())["study"]["ranges"]["noise_rate_hz"] == rate


@pytest.mark.parametrize("value, message", [("0", "positive"), ("nan", "positive"), ("2000", "exceeds"),
                                            ("300", "whole multiple")])
def test_cli_bad_rate(run_cli, value, message):
    code, out, err = run_cli("montecarlo", "--certificate", str(CERT), "--samples", "1", "--rate", value)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
