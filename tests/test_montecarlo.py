"""Monte Carlo robustness studies: statistics, reproducibility, executors (local pool, Dask) and the CLI.

Reference values are independent of :mod:`nniquad.study`: closed forms of
the Wilson interval and of the order-statistic median interval, numpy's own
``SeedSequence.spawn`` streams, the certificate's stored ``full`` run, and the
thrust limit ``4 b ω_max² < m g``.
"""

from __future__ import annotations

import json
import math
import socket
import time
from dataclasses import replace

import numpy as np
import pytest

from nniquad.analysis.cascade.box_certificate import ParameterBox

import nniquad.study as mc
from nniquad.study import executors
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.laws.nni import Gains
from nniquad.model.vehicle import PAPER_VEHICLE

# tuned gains: the full model settles in 1.53 s from (2, -1.5) m; certified reach 3.66 m
GAINS = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56021438245625, attitude_zeta=1.1320049751084362,
                       attitude_accel_limit_rad_s2=31.13986455385077)

# the test design tolerates only a slightly slower motor: its cascade box is a tenth of the Monte Carlo
# ranges (log scale), as the widest-box search finds
SMALL_BOX = ParameterBox.monte_carlo_default().scaled(0.1)
REACH_M = 3.6623140976540345
Z95 = 1.959963984540054  # standard normal 97.5 % quantile

#: Ranges inside which every scenario of these gains settles to the setpoint (checked in
#: test_known_bad_scenarios_fail): the equilibrium of a 0.03 N wind, F / (m̂ kp - 1/δ) = 2.3 cm, lies inside the 5 cm band.
BENIGN = mc.ScenarioRanges(mass_factor=(0.9, 1.1), inertia_factor=(0.9, 1.1), attitude_gain_factor=(0.9, 1.1),
                           tau_motor_s=(0.005, 0.015), noise_sigma_m=(0.0, 0.0), wind_N=(0.0, 0.03))
#: CLI options of a study with both outcomes: up to 2.4 x the mass of a vehicle with thrust-to-weight 2.02
#: (seed 1, 4 s; a wind of at most 1 % of the weight, whose equilibrium lies inside the band).
MIXED = ["--mass-range", "1.0", "2.4", "--tau-motor-range", "0.005", "0.03", "--noise-range", "0", "0.002",
         "--wind-fraction-range", "0", "0.01"]


def build_mc_certificate() -> dict:
    """A real certificate of the tuned gains over :data:`SMALL_BOX` (JSON): test_certificate's, shared with it
    (:data:`MC_CERTIFICATE` names it for ``shared_json``), so the session builds one certificate, not two."""
    from tests.test_certificate import build_small_certificate

    return build_small_certificate()


#: The ``shared_json`` name of :func:`build_mc_certificate`'s document (test_certificate's small certificate).
MC_CERTIFICATE = "small-certificate"


@pytest.fixture(scope="session")
def cert_path(tmp_path_factory, shared_json):
    """A real certificate of the tuned gains, built once per test session (:func:`build_mc_certificate`)."""
    from nniquad.certificates.certificate import write_certificate

    return write_certificate(shared_json(MC_CERTIFICATE, build_mc_certificate),
                             tmp_path_factory.mktemp("mc") / "cert.json")


@pytest.fixture(scope="module")
def setup4():
    """Study setup without a certificate file: 4 s horizon, the certified reach as displacement radius."""
    return mc.study_setup_from(PAPER_VEHICLE, GAINS, inner=INNER, region_m=REACH_M, horizon_s=4.0)


def _one_line_error(code, out, err, *needles):
    assert code not in (0, None), (code, out, err)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("nniquad montecarlo: error: "), err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], lines[0]


# ----------------------------------------------------------------------------- statistics


def test_wilson_interval_hand_computed():
    # k = 8, n = 10, z = 1.95996: p = 0.8, z²/n = 0.384146, den = 1.384146,
    # centre = (0.8 + 0.192073) / den = 0.716740,
    # half = z / den * sqrt(0.8 * 0.2 / 10 + z² / 400) = 1.416010 * 0.160011 = 0.226578
    lo, hi = mc.wilson_interval(8, 10)
    assert lo == pytest.approx(0.490163, abs=2e-6)
    assert hi == pytest.approx(0.943318, abs=2e-6)
    # closed forms at the ends: k = 0 -> [0, z²/(n + z²)], k = n -> [n/(n + z²), 1]
    z2 = Z95**2
    assert mc.wilson_interval(0, 10) == pytest.approx((0.0, z2 / (10 + z2)), abs=1e-12)
    assert mc.wilson_interval(25, 25) == pytest.approx((25 / (25 + z2), 1.0), abs=1e-12)
    # a 99 % interval is wider
    lo99, hi99 = mc.wilson_interval(8, 10, confidence=0.99)
    assert lo99 < lo and hi99 > hi


def test_pareto_front_by_hand():
    """cost = settling [s], benefit = success; dominated, tied and non-finite points are left out."""
    cost = [2.0, 1.5, 3.0, 1.5, None, 2.5, 1.0, float("nan")]
    benefit = [0.9, 0.8, 1.0, 0.7, 1.0, 0.9, 0.2, 1.0]
    # by hand: 1.0 s (0.2) -> 1.5 s (0.8; the 0.7 tie loses) -> 2.0 s (0.9; 2.5 s is no better) -> 3.0 s (1.0)
    assert mc.pareto_front(cost, benefit) == [6, 1, 0, 2]
    assert mc.pareto_front([], []) == []
    with pytest.raises(ValueError):
        mc.pareto_front([1.0], [0.5, 0.6])


def test_quantile_ci_order_statistics():
    # classic table: for n = 10 the 95 % median interval is [x(2), x(9)] (coverage 1 - 2 * 11/1024 = 97.9 %)
    x = np.arange(1.0, 11.0)[::-1]  # order of the input must not matter
    assert mc.quantile_ci(x, 0.5) == (5.0, 2.0, 9.0)
    value, lo, hi = mc.quantile_ci(x, 0.99)  # too few samples to bound p99 from above
    assert value == 10.0 and hi == math.inf and lo <= value
    # failures counted as +inf push the quantile to "never"
    assert mc.quantile_ci([1.0, math.inf, math.inf], 0.5)[0] == math.inf


# ----------------------------------------------------------------------------- reproducibility


def test_scenario_streams_match_seedsequence_spawn(setup4):
    seed = 7
    many = mc.draw_scenarios(12, seed, mc.DEFAULT_RANGES, setup4)
    few = mc.draw_scenarios(5, seed, mc.DEFAULT_RANGES, setup4)
    assert many[:5] == few  # scenario i does not depend on how many are drawn
    assert mc.draw_scenario(9, seed, mc.DEFAULT_RANGES, setup4) == many[9]
    # scenario i's first draw is the mass factor, from numpy's own i-th spawned stream
    children = np.random.SeedSequence(seed).spawn(12)
    for i in (0, 3, 11):
        rng = np.random.default_rng(children[i])
        expected = rng.uniform(*mc.DEFAULT_RANGES.mass_factor)
        assert dict(many[i].factors)["mass"] == expected
        assert many[i].sim_params.plant.m == pytest.approx(PAPER_VEHICLE.m * expected, rel=1e-15)
    assert mc.draw_scenarios(5, seed + 1, mc.DEFAULT_RANGES, setup4) != few
    # every start lies in the displacement disk, at most the certified reach
    assert setup4.region_m == pytest.approx(REACH_M)
    assert all(math.hypot(*s.xi0_m) <= REACH_M for s in many)
    assert all(s.horizon_s == 4.0 for s in many)  # a setup keeps its own horizon


def test_results_independent_of_batch_size_and_order(setup4):
    scenarios = mc.draw_scenarios(8, 3, BENIGN.with_(tau_motor_s=(0.005, 0.03), noise_sigma_m=(0.0, 0.002)), setup4)
    one = mc.run_study(scenarios, workers=1, batch_size=8)
    three = mc.run_study(scenarios, workers=1, batch_size=3)
    backwards = mc.run_scenarios(scenarios[::-1])
    assert one.results == three.results
    assert one.results == sorted(backwards, key=lambda r: r.index)
    assert [r.index for r in one.results] == list(range(8))
    assert mc.summarize(backwards).to_json() == mc.summarize(one.results).to_json()
    assert one.batch_size == 8 and three.batch_size == 3 and not one.partial


# ----------------------------------------------------------------------------- outcomes


def test_known_bad_scenarios_fail(setup4):
    """Scenarios heavier than the rotors can lift (4 b ω_max² < m g) fail; their neighbours succeed."""
    v = PAPER_VEHICLE
    liftable = 4 * v.b * v.omega_max**2 / v.g  # heaviest mass the rotors can hold [kg]
    scenarios = mc.draw_scenarios(6, 2, BENIGN, setup4)
    bad = {1, 4}
    scenarios = [s.with_params(plant={"m": 1.3 * liftable}) if s.index in bad else s for s in scenarios]
    results = mc.run_study(scenarios, workers=1).results
    for r in results:
        if r.index in bad:
            assert r.scenario["thrust_to_weight"] == pytest.approx(1 / 1.3)
            assert not r.success and r.failure in ("altitude lost", "diverged"), r
            assert r.settling_s is None
        else:
            assert r.success and r.failure is None, r
            assert 0 < r.settling_s < 4.0 and r.max_altitude_dev_m < 2.0
    summary = mc.summarize(results, n_worst=3)
    assert summary.n_success == 4 and summary.success_rate == pytest.approx(4 / 6)
    assert summary.success_ci == mc.wilson_interval(4, 6)
    assert sum(summary.failures.values()) == 2
    assert {r.index for r in summary.worst[:2]} == bad  # failures are listed first
    assert math.isinf(summary.settling["p95"][0])  # 2 of 6 never settle: p95 is "never"


def test_nominal_scenario_reproduces_the_certificate(cert_path):
    """No perturbation, continuous measurement: the certificate's own ``full`` run (via simulate()).

    The study itself samples at the certificate's rate with the NNI controller in discrete
    time: that nominal scenario is a different, slower run.
    """
    from nniquad.certificates.certificate import load_certificate

    cert = load_certificate(cert_path)
    setup = mc.study_setup(cert, horizon_s=6.0)
    base = setup.base
    assert base.inner.attitude_accel_limit_rad_s2 == cert["inner_loop"]["attitude_accel_limit_rad_s2"]
    assert base.inner.attitude_wn_rad_s == cert["inner_loop"]["attitude_wn_rad_s"] and base.run.motor_lag == 1.0
    assert setup.region_m == pytest.approx(cert["region_of_attraction"]["max_displacement_m"])
    assert setup.label == "sha256:" + cert["digest"]["value"][:16]
    assert setup.controller_sampling == "discrete" and base.run.discrete == 1.0
    s = mc.draw_scenario(0, 0, mc.DEFAULT_RANGES, setup)
    ref = cert["performance"]["full"]
    # the certificate's full run is what flies: sampled at the certified rate, NNI controller in discrete time
    assert ref["settings"]["controller_sampling"] == "discrete"
    assert ref["settings"]["noise_rate_hz"] == cert["cascade"]["rate_hz"] == 1.0 / base.run.sample_period
    nominal = replace(s, params=tuple(float(v) for v in base.vector()), xi0_m=tuple(cert["xi0_m"]),
                      noise_sigma_m=0.0)
    r = mc.run_scenarios([nominal])[0]
    assert r.success
    assert r.settling_s == pytest.approx(ref["settling_s"], abs=2e-3)  # 10 ms vs 5 ms output sampling
    assert r.peak_tilt_deg == pytest.approx(ref["peak_tilt_deg"], abs=0.05)
    # the continuous-measurement run of the same scenario is a different run (the sampling is modelled)
    continuous = tuple(float(v) for v in base.with_(run={"sample_hold": 0.0, "discrete": 0.0}).vector())
    c = mc.run_scenarios([replace(nominal, params=continuous, controller_sampling="continuous")])[0]
    assert c.success and abs(c.settling_s - r.settling_s) > 5e-3


# ----------------------------------------------------------------------------- executors


def test_dask_cluster_equals_local_pool(run_cli, cert_path, tmp_path):
    """Same seed: a 2-process Dask cluster, the 2-process local pool and one process give identical results."""
    distributed = pytest.importorskip("distributed")

    common = ["montecarlo", "--certificate", str(cert_path), "--samples", "8", "--seed", "1", "--horizon", "4",
              *MIXED]
    pool_json = tmp_path / "pool.json"
    code, out, err = run_cli(*common, "--workers", "2", "--batch-size", "2", "--json", str(pool_json))
    assert code == 0, err
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        dask_json = tmp_path / "dask.json"
        code, out, err = run_cli(*common, "--scheduler", cluster.scheduler_address, "--batch-size", "3",
                                 "--json", str(dask_json))
        assert code == 0, err
    assert "[montecarlo]" in err and "done" in err  # progress on stderr
    pool, dask = json.loads(pool_json.read_text()), json.loads(dask_json.read_text())
    assert dask["run"]["executor"].startswith("dask tcp://127.0.0.1:") and dask["run"]["workers"] == 2
    assert pool["run"]["executor"] == "local process pool" and pool["run"]["workers"] == 2
    assert dask["results"] == pool["results"]  # exact, per scenario
    assert dask["summary"] == pool["summary"]
    outcomes = {r["success"] for r in pool["results"]}
    assert outcomes == {True, False}  # the comparison covers both kinds of outcome
    # a third executor: this process, one batch
    from nniquad.certificates.certificate import load_certificate

    ranges = mc.ScenarioRanges(mass_factor=(1.0, 2.4), tau_motor_s=(0.005, 0.03), noise_sigma_m=(0.0, 0.002),
                               wind_weight_fraction=(0.0, 0.01))  # MIXED
    setup = mc.study_setup(load_certificate(cert_path), ranges, horizon_s=4.0)
    here = mc.run_scenarios(mc.draw_scenarios(8, 1, ranges, setup))
    assert json.loads(json.dumps([r.to_json() for r in here])) == pool["results"]


# ----------------------------------------------------------------------------- command line


def test_cli_study_json_and_rerun(run_cli, cert_path, tmp_path):
    js = tmp_path / "study.json"
    code, out, err = run_cli("montecarlo", "--certificate", str(cert_path), "--samples", "6", "--seed", "4",
                             "--horizon", "3", "--workers", "1", "--json", str(js), *MIXED)
    assert code == 0, err
    for text in ("success rate", "settling time p50", "settling time p99", "peak tilt p95", " deg", " %",
                 "--seed 4", "--rerun INDEX"):
        assert text in out, text
    data = json.loads(js.read_text())
    assert data["partial"] is False and data["completed"] == data["requested"] == 6
    s = data["summary"]
    assert set(s["settling_s"]) == {"p50", "p95", "p99"} and len(s["success_rate_ci95"]) == 2
    assert s["n"] == 6 and [r["index"] for r in data["results"]] == list(range(6))
    assert s["worst_cases"] and all(w["study_seed"] == 4 for w in s["worst_cases"])
    # the worst case, rerun alone, gives the same result
    worst = s["worst_cases"][0]["index"]
    rr = tmp_path / "rerun.json"
    code, out, err = run_cli("montecarlo", "--certificate", str(cert_path), "--seed", "4", "--horizon", "3",
                             *MIXED, "--rerun", f"{worst},5", "--json", str(rr))
    assert code == 0, err
    assert f"scenario {worst} of seed 4" in out
    again = json.loads(rr.read_text())["rerun"]
    assert again == [data["results"][worst], data["results"][5]]
    assert not list(tmp_path.glob("*.tmp"))


def test_cli_interrupt_keeps_finished_batches(run_cli, cert_path, tmp_path, monkeypatch):
    """Ctrl-C after the first batch: that batch is saved in FILE.partial.json, marked partial."""
    real = mc.run_scenarios

    def interrupted_on_second_batch(batch):
        if any(s.index == 2 for s in batch):  # the first scenario of the second batch of 2
            raise KeyboardInterrupt
        return real(batch)

    monkeypatch.setattr(executors, "run_scenarios", interrupted_on_second_batch)
    js = tmp_path / "study.json"
    code, out, err = run_cli("montecarlo", "--certificate", str(cert_path), "--samples", "6", "--horizon", "2",
                             "--workers", "1", "--batch-size", "2", "--json", str(js))
    assert code == 130
    assert not js.exists()
    part = tmp_path / "study.partial.json"
    data = json.loads(part.read_text())
    assert data["partial"] is True and data["summary"]["partial"] is True
    assert data["completed"] == 2 and data["requested"] == 6
    assert [r["index"] for r in data["results"]] == [0, 1]
    assert "PARTIAL" in out and "partial" in err
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.parametrize("samples", ["0", "-3"])
def test_cli_rejects_non_positive_samples(run_cli, cert_path, tmp_path, samples):
    js = tmp_path / "out.json"
    code, out, err = run_cli("montecarlo", "--certificate", str(cert_path), "--samples", samples,
                             "--json", str(js))
    _one_line_error(code, out, err, "--samples", "positive")
    assert not js.exists()


def _closed_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("address, needle", [
    (None, "cannot reach the Dask scheduler"),  # nothing listens on the port
    ("tcp://localhost", "tcp://host:port"),  # no port
    ("tcp://127.0.0.1:notaport", "tcp://host:port"),
])
def test_cli_unreachable_scheduler_fails_fast(run_cli, cert_path, tmp_path, address, needle):
    pytest.importorskip("distributed")
    address = address or f"tcp://127.0.0.1:{_closed_port()}"
    js = tmp_path / "out.json"
    t0 = time.perf_counter()
    code, out, err = run_cli("montecarlo", "--certificate", str(cert_path), "--samples", "4",
                             "--scheduler", address, "--json", str(js))
    assert time.perf_counter() - t0 < mc.CONNECT_TIMEOUT_S  # refused at once, no retry loop
    _one_line_error(code, out, err, needle)
    assert not js.exists() and out == ""


def test_silent_server_times_out():
    """A port that accepts connections but never answers: one-line error after the timeout, not a hang."""
    pytest.importorskip("distributed")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as server:
        server.bind(("127.0.0.1", 0))
        server.listen(4)
        address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
        t0 = time.perf_counter()
        with pytest.raises(mc.MonteCarloError, match="no answer within 0.5 s"):
            mc.connect_scheduler(address, timeout_s=0.5)
        assert time.perf_counter() - t0 < 3.0


def test_cli_rejects_tampered_certificate(run_cli, cert_path, tmp_path):
    cert = json.loads(cert_path.read_text())
    cert["gains"]["kp"] *= 1.01  # a changed gain, digest left as it was
    bad = tmp_path / "tampered.json"
    bad.write_text(json.dumps(cert))
    code, out, err = run_cli("montecarlo", "--certificate", str(bad), "--samples", "4")
    _one_line_error(code, out, err, "digest mismatch")
    assert out == ""


def test_motor_time_constant_range_is_relative_to_the_vehicle(setup4):
    """Default: tau_motor = nominal x U[0.5, 2] (config), for a 5 ms motor as for the paper's 20 ms."""
    from nniquad import config

    lo, hi = config.TAU_MOTOR_FACTOR_RANGE
    assert mc.DEFAULT_RANGES.tau_motor_s is None and mc.DEFAULT_RANGES.tau_motor_factor == (lo, hi)
    for tau_nom in (0.005, 0.02):
        vehicle = replace(PAPER_VEHICLE, tau_motor=tau_nom)
        setup = mc.study_setup_from(vehicle, GAINS, inner=INNER, horizon_s=1.0)
        taus = np.array([s.sim_params.plant.tau_motor for s in mc.draw_scenarios(200, 5, mc.DEFAULT_RANGES, setup)])
        assert np.all(taus >= lo * tau_nom) and np.all(taus <= hi * tau_nom)
        assert taus.min() < 0.6 * tau_nom and taus.max() > 1.9 * tau_nom  # the whole range is used
    # an absolute range still wins, drawn from the same stream position
    setup = mc.study_setup_from(PAPER_VEHICLE, GAINS, inner=INNER, horizon_s=1.0)
    rel = mc.draw_scenario(3, 5, mc.DEFAULT_RANGES, setup)
    ab = mc.draw_scenario(3, 5, mc.DEFAULT_RANGES.with_(tau_motor_s=(0.01, 0.04)), setup)
    f = (rel.sim_params.plant.tau_motor / PAPER_VEHICLE.tau_motor - lo) / (hi - lo)
    assert ab.sim_params.plant.tau_motor == pytest.approx(0.01 + f * 0.03, rel=1e-12)
    assert ab.sim_params.plant.m == rel.sim_params.plant.m


def test_default_wind_is_a_fraction_of_each_vehicles_weight():
    """The default wind range scales with the vehicle: a 30 g Crazyflie gets the same share of its own weight."""
    from nniquad.config import WIND_WEIGHT_FRACTION_RANGE
    from nniquad.laws.nni import Gains
    from nniquad.model.vehicle import PAPER_VEHICLE
    from nniquad.study import DEFAULT_RANGES, draw_scenarios, study_setup_from

    light = PAPER_VEHICLE.with_(m=0.03, Jx=1.4e-5, Jy=1.4e-5, Jz=2.2e-5, b=1.8e-8, omega_max=2500.0, l=0.04)
    for vehicle in (PAPER_VEHICLE, light):
        gains = Gains(kp=20.0, Gamma=40.0, delta=1.0 / (0.7 * vehicle.m * 20.0))
        setup = study_setup_from(vehicle, gains)
        scen = draw_scenarios(200, 5, DEFAULT_RANGES, setup)
        frac = np.array([s.describe()["wind_fraction_of_weight"] for s in scen])
        force = np.array([s.describe()["wind_magnitude_N"] for s in scen])
        weight = vehicle.m * vehicle.g
        np.testing.assert_allclose(force, frac * weight, rtol=1e-12)
        assert frac.min() >= WIND_WEIGHT_FRACTION_RANGE[0] and frac.max() <= WIND_WEIGHT_FRACTION_RANGE[1]
        assert frac.max() > 0.9 * WIND_WEIGHT_FRACTION_RANGE[1]  # the range is really used, not collapsed
    # an absolute range, when given, wins (and the draw keeps its position in the stream)
    absolute = DEFAULT_RANGES.with_(wind_N=(0.0, 0.1))
    a = draw_scenarios(20, 5, absolute, setup)
    b = draw_scenarios(20, 5, DEFAULT_RANGES, setup)
    assert all(s.describe()["wind_magnitude_N"] <= 0.1 for s in a)
    assert [s.xi0_m for s in a] == [s.xi0_m for s in b]


# ----------------------------------------------------------------------------- PD comparison laws


@pytest.mark.parametrize("pd_gains", [pytest.param(("pd_velocity", (4.0, 3.6)), id="pd_velocity"),
                                      pytest.param(("pd_filtered", (4.0, 3.6, 0.05)), id="pd_filtered")])
def test_pd_laws_run_on_the_same_scenarios(pd_gains):
    """A PD law is studied on the NNI law's scenarios: same plant draws, its own gain layout and equilibrium.

    The reference for the wind equilibrium is a direct simulation of the perturbed
    plant with a constant wind and no noise, held until the motion has died out:
    the static balance ``F = m̂ k_p ξ`` of a PD law (hand derivation: the derivative
    term vanishes at rest).
    """
    from nniquad.laws.pd_filtered import PDFilteredGains
    from nniquad.laws.pd_velocity import PDGains
    from nniquad.sim import SimOptions, simulate

    law, values = pd_gains
    gains = (PDGains if law == "pd_velocity" else PDFilteredGains)(*values)
    setup_pd = mc.study_setup_from(PAPER_VEHICLE, gains, inner=INNER, region_m=REACH_M, horizon_s=4.0)
    setup_nni = mc.study_setup_from(PAPER_VEHICLE, GAINS, inner=INNER, region_m=REACH_M, horizon_s=4.0)
    assert setup_pd.controller == law and setup_pd.to_json()["controller"] == law
    pd_s, nni_s = mc.draw_scenario(5, 9, mc.DEFAULT_RANGES, setup_pd), mc.draw_scenario(5, 9, mc.DEFAULT_RANGES, setup_nni)
    assert pd_s.sim_params.gains == gains
    assert pd_s.describe() == nni_s.describe()  # common random numbers across laws
    # the wind equilibrium: F / (m̂ kp), against a 30 s windy run from rest at the origin
    s = pd_s.with_params(run={"wind_x": 0.2, "wind_y": -0.1})
    eq = s.equilibrium_m()
    assert eq == pytest.approx((0.2 / (PAPER_VEHICLE.m * gains.kp), -0.1 / (PAPER_VEHICLE.m * gains.kp)))
    res = simulate(None, None, SimOptions(model="full", horizon_s=30.0, xi0=(0.0, 0.0), sample_hold=True),
                   params=[s.sim_params])
    assert res.xy[0, -1] == pytest.approx(eq, abs=1e-4)
    r = mc.run_study([mc.draw_scenario(i, 9, BENIGN, setup_pd) for i in range(3)], workers=1).results
    assert all(x.success for x in r), r
