"""A Monte Carlo study that follows a reference: the scenarios start on it, succeed unless the vehicle is lost, and
the summary gives the tracking error's quantiles in place of the settling time's."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import nniquad.study as mc
from nniquad.control.references import FigureEight
from nniquad.errors import EXIT_USER_ERROR
from nniquad.laws.nni import Gains
from nniquad.model.vehicle import PAPER_VEHICLE
from nniquad.sim import SimOptions, simulate
from nniquad.study.runs import ScenarioResult

GAINS = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)  # test_montecarlo's tuned design
EIGHT = FigureEight(2.0, 1.0, 8.0)
BENIGN = mc.ScenarioRanges(mass_factor=(0.9, 1.1), inertia_factor=(0.9, 1.1), attitude_gain_factor=(0.9, 1.1),
                           tau_motor_s=(0.005, 0.015), noise_sigma_m=(0.0, 0.0), wind_N=(0.0, 0.1),
                           max_displacement_m=0.2)


def test_scenarios_follow_the_reference_from_its_start():
    setup = replace(mc.study_setup_from(PAPER_VEHICLE, GAINS, ranges=BENIGN, horizon_s=3.0), reference=EIGHT,
                    feedforward=True)
    scenarios = mc.draw_scenarios(3, 5, BENIGN, setup)
    results = mc.run_scenarios(scenarios)
    assert all(r.success and r.settling_s is None and 0 < r.tracking_rms_m <= r.tracking_max_m for r in results)
    # the same scenario flown by hand: on the reference plus the drawn displacement, with the reference's velocity
    s = scenarios[0]
    p, v, _ = EIGHT.sample(0.0)
    o = SimOptions(model="full", horizon_s=3.0, controller_sampling=s.controller_sampling,
                   noise_rate_hz=s.noise_rate_hz, xi0=tuple(p[0] + s.xi0_m), v0=tuple(v[0]), reference=EIGHT,
                   feedforward=True)
    tr, = simulate(None, None, o, params=[s.sim_params])
    assert np.hypot(*(tr.xy[0] - p[0])) == np.hypot(*s.xi0_m) > 0
    assert results[0].tracking_rms_m == tr.tracking().tracking_rms_m
    assert ScenarioResult.from_json(results[0].to_json()) == results[0]
    summary = mc.summarize(results)
    assert summary.settling == {} and set(summary.tracking) == {"p50", "p95", "p99"}
    assert summary.tracking["p99"][0] == max(r.tracking_rms_m for r in results)
    assert "tracking RMS p50" in summary.table() and "tracking_rms_m" in summary.to_json()
    assert setup.to_json()["reference"]["type"] == "FigureEight"


def test_a_reference_is_refused_with_within_certificate(run_cli, tmp_path):
    code, out, err = run_cli("montecarlo", "--certificate", str(tmp_path / "none.json"), "--samples", "2",
                             "--reference", "figure8:2,1,8", "--within-certificate")
    assert code == EXIT_USER_ERROR and "no certificate covers a moving reference" in err and "Traceback" not in err
