"""Time-optimal bound: IPOPT against the bang-bang closed forms, and the CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from nniquad.analysis.bound import (
    bang_bang_enter_band,
    bang_bang_rest_to_rest,
    max_horizontal_acceleration,
    thrust_tilt_limit_deg,
    time_optimal_bound,
)
from nniquad.errors import SimulationError
from nniquad.model.vehicle import PAPER_VEHICLE

# IPOPT's transcription holds the acceleration piecewise constant, so its optimum
# is above the continuous one by O(h²) (the switch is not a node); 1e-3 relative
# is 1 ms on the paper's ~1.2 s, far looser than what 200 intervals deliver.
REL_TOL = 1e-3


@pytest.fixture(scope="module")
def paper():
    return time_optimal_bound()


def test_paper_vehicle_numbers_by_hand(paper):
    a = 9.81 * math.tan(math.radians(30.0))
    assert paper.a_max_m_s2 == pytest.approx(a, rel=1e-12)
    assert paper.distance_m == pytest.approx(2.5) and paper.band_radius_m == pytest.approx(0.05)
    # Rest to rest over 2.45 m: half accelerating, half braking.
    assert paper.rest_to_rest_closed_form_s == pytest.approx(2 * math.sqrt(2.45 / a), rel=1e-12)
    assert paper.rest_to_rest_closed_form_s == pytest.approx(1.315, abs=5e-4)


@pytest.mark.parametrize("case", ["rest_to_rest", "enter_band"])
def test_ipopt_matches_closed_form_on_paper_vehicle(paper, case):
    ipopt = getattr(paper, f"{case}_s")
    closed = getattr(paper, f"{case}_closed_form_s")
    assert ipopt == pytest.approx(closed, rel=REL_TOL)
    # The discrete problem is a restriction of the continuous one: never faster
    # (up to IPOPT's 1e-8 constraint relaxation).
    assert ipopt >= closed * (1 - 1e-7)
    assert paper.solver[case]["return_status"] == "Solve_Succeeded"


def test_enter_band_is_faster_than_rest_to_rest(paper):
    assert paper.enter_band_s < paper.rest_to_rest_s
    assert paper.enter_band_closed_form_s < paper.rest_to_rest_closed_form_s


def test_optimal_trajectories_respect_the_limits(paper):
    a, r = paper.a_max_m_s2, paper.band_radius_m
    for case, tr in paper.trajectories.items():
        assert np.allclose(tr.xy[0], [2.0, -1.5]) and np.allclose(tr.v[0], 0.0)
        assert np.max(np.hypot(*tr.a.T)) <= a * (1 + 1e-6)
        assert np.hypot(*tr.xy[-1]) <= r * (1 + 1e-6)
        # Straight-line motion: no component across the initial direction.
        e_perp = np.array([0.6, 0.8])
        assert np.max(np.abs(tr.xy @ e_perp)) < 1e-6
    vf = paper.trajectories["enter_band"].v[-1]
    stop = paper.trajectories["enter_band"].xy[-1] + vf * np.hypot(*vf) / (2 * a)
    assert np.hypot(*stop) <= r * (1 + 1e-6)
    # The entry speed is the largest that still stops inside: sqrt(4 a r).
    assert np.hypot(*vf) == pytest.approx(math.sqrt(4 * a * r), rel=1e-3)
    assert np.allclose(paper.trajectories["rest_to_rest"].v[-1], 0.0, atol=1e-9)


def test_second_vehicle_and_tilt_limit():
    mars = PAPER_VEHICLE.with_(name="paper vehicle on Mars", g=3.71)
    res = time_optimal_bound(mars, xi0=(-1.0, 3.0), tilt_limit_deg=20.0)
    a = 3.71 * math.tan(math.radians(20.0))
    D = math.hypot(1.0, 3.0)
    assert res.a_max_m_s2 == pytest.approx(a, rel=1e-12)
    assert res.rest_to_rest_s == pytest.approx(bang_bang_rest_to_rest(D, 0.02 * D, a), rel=REL_TOL)
    assert res.enter_band_s == pytest.approx(bang_bang_enter_band(D, 0.02 * D, a), rel=REL_TOL)


def test_short_distance_branch_of_enter_band():
    # A wide band (40 %: D = 2.5 r < 3 r): full acceleration never exceeds the
    # stoppable entry speed, so the bound is sqrt(2 (D - r) / a).
    res = time_optimal_bound(band_fraction=0.4)
    L = 2.5 - 1.0
    assert res.enter_band_closed_form_s == pytest.approx(math.sqrt(2 * L / res.a_max_m_s2), rel=1e-12)
    assert res.enter_band_s == pytest.approx(res.enter_band_closed_form_s, rel=REL_TOL)


def test_thrust_limit_caps_the_tilt():
    # Thrust-to-weight 1.2: at most arccos(1/1.2) ≈ 33.6 deg while holding
    # altitude, where g tan(tilt) = g sqrt(TW² - 1).
    weak = PAPER_VEHICLE.with_(omega_max=PAPER_VEHICLE.hover_rotor_speed() * math.sqrt(1.2))
    assert thrust_tilt_limit_deg(weak) == pytest.approx(math.degrees(math.acos(1 / 1.2)), rel=1e-9)
    assert max_horizontal_acceleration(weak, 45.0) == pytest.approx(9.81 * math.sqrt(1.2**2 - 1), rel=1e-9)
    assert max_horizontal_acceleration(weak, 20.0) == pytest.approx(9.81 * math.tan(math.radians(20.0)), rel=1e-12)


def test_closed_forms_are_consistent():
    a, D, r = 5.0, 2.5, 0.05
    # Enter-band = rest-to-rest to the far edge minus the final braking inside.
    assert bang_bang_enter_band(D, r, a) == pytest.approx(2 * math.sqrt((D + r) / a) - 2 * math.sqrt(r / a), rel=1e-12)
    # The two branches meet at D = 3 r.
    assert bang_bang_enter_band(3 * r * (1 + 1e-12), r, a) == pytest.approx(bang_bang_enter_band(3 * r, r, a), rel=1e-9)
    assert bang_bang_rest_to_rest(r / 2, r, a) == 0.0 and bang_bang_enter_band(r / 2, r, a) == 0.0


@pytest.mark.parametrize(
    "kwargs",
    [
        {"tilt_limit_deg": 0.0},
        {"tilt_limit_deg": 90.0},
        {"tilt_limit_deg": float("nan")},
        {"xi0": (0.0, 0.0)},
        {"xi0": (float("inf"), 1.0)},
        {"xi0": (1.0,)},
        {"band_fraction": 0.0},
        {"n_intervals": 1},
    ],
)
def test_bad_options_raise_domain_errors(kwargs):
    with pytest.raises(SimulationError):
        time_optimal_bound(**kwargs)


# -------------------------------------------------------------------------- CLI


def test_cli_prints_table_and_writes_json(run_cli, tmp_path):
    path = tmp_path / "bound.json"
    code, out, err = run_cli("bound", "--json", str(path))
    assert code == 0, err
    assert "rest_to_rest" in out and "enter_band" in out and "m/s^2" in out
    data = json.loads(path.read_text())
    assert data["rest_to_rest_s"] == pytest.approx(data["rest_to_rest_closed_form_s"], rel=REL_TOL)
    assert data["enter_band_s"] == pytest.approx(data["enter_band_closed_form_s"], rel=REL_TOL)
    assert data["enter_band_s"] < data["rest_to_rest_s"]


def test_cli_options_change_the_bound(run_cli, tmp_path):
    path = tmp_path / "b.json"
    code, _, err = run_cli("bound", "--tilt-limit", "45", "--xi0", "3", "4", "--json", str(path))
    assert code == 0, err
    data = json.loads(path.read_text())
    assert data["a_max_m_s2"] == pytest.approx(9.81, rel=1e-12)  # tan 45° = 1
    assert data["rest_to_rest_closed_form_s"] == pytest.approx(2 * math.sqrt(4.9 / 9.81), rel=1e-12)


@pytest.mark.parametrize(
    "argv",
    [
        ("--tilt-limit", "0"),
        ("--tilt-limit", "90"),
        ("--tilt-limit", "-5"),
        ("--tilt-limit", "nan"),
        ("--xi0", "0", "0"),
        ("--xi0", "inf", "1"),
    ],
)
def test_cli_bad_options_exit_2_with_one_line(run_cli, argv):
    code, out, err = run_cli("bound", *argv)
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert err.startswith("nniquad bound: error:")
    assert "Traceback" not in err


# ------------------------------------------------------------------ edges found by mutation testing
# (the survivors of `make mutation MODULE=bound`; each value is derived by hand or from the definitions)


def test_enter_band_closed_form_in_the_short_branch_by_hand():
    # a = 1, D = 1, r = 0.4: L = 0.6, w^2 = 4 a r = 1.6 >= 2 a L = 1.2, so full acceleration: sqrt(2 L / a)
    assert bang_bang_enter_band(1.0, 0.4, 1.0) == pytest.approx(math.sqrt(1.2), rel=1e-15)
    # check the branch by its definition: accelerating at a over L = 0.6 m ends at speed sqrt(1.2) < w
    assert math.sqrt(2 * 1.0 * 0.6) < math.sqrt(1.6)


def test_result_json_fields_are_the_interface(paper):
    data = paper.to_json()
    assert set(data) == {"vehicle", "xi0_m", "distance_m", "band_fraction", "band_radius_m", "tilt_limit_deg",
                         "thrust_tilt_limit_deg", "effective_tilt_limit_deg", "a_max_m_s2", "rest_to_rest_s",
                         "enter_band_s", "rest_to_rest_closed_form_s", "enter_band_closed_form_s",
                         "rest_to_rest_rel_error", "enter_band_rel_error", "n_intervals", "solver", "trajectories"}
    from nniquad.analysis.bound import DEFAULT_N_INTERVALS
    from nniquad.config import BAND_FRACTION, TILT_LIMIT_DEG, XI0_M

    assert data["vehicle"] == PAPER_VEHICLE.name and data["xi0_m"] == list(XI0_M)
    D = math.hypot(*XI0_M)
    assert data["distance_m"] == pytest.approx(D, rel=1e-15)
    assert data["band_radius_m"] == pytest.approx(BAND_FRACTION * D, rel=1e-15)
    assert data["band_fraction"] == BAND_FRACTION and data["n_intervals"] == DEFAULT_N_INTERVALS
    # the paper vehicle's thrust allows more than the tilt limit, so the limit is the effective one
    assert data["tilt_limit_deg"] == TILT_LIMIT_DEG and data["effective_tilt_limit_deg"] == TILT_LIMIT_DEG
    assert data["thrust_tilt_limit_deg"] == pytest.approx(thrust_tilt_limit_deg(PAPER_VEHICLE), rel=1e-15)
    for case in ("rest_to_rest", "enter_band"):
        rel = (data[f"{case}_s"] - data[f"{case}_closed_form_s"]) / data[f"{case}_closed_form_s"]
        assert data[f"{case}_rel_error"] == pytest.approx(rel, rel=1e-12)
        info = data["solver"][case]
        assert set(info) == {"return_status", "iterations", "wall_time_s"}
        assert info["return_status"] == "Solve_Succeeded" and info["iterations"] >= 1
        assert 0.0 < info["wall_time_s"] < 60.0
        traj = data["trajectories"][case]
        assert set(traj) == {"t_s", "xy_m", "v_m_s", "a_m_s2"}
        n = DEFAULT_N_INTERVALS
        assert len(traj["t_s"]) == len(traj["xy_m"]) == len(traj["v_m_s"]) == n + 1 and len(traj["a_m_s2"]) == n
    assert set(data["trajectories"]) == {"rest_to_rest", "enter_band"}
    assert "trajectories" not in paper.to_json(include_trajectories=False)
    json.dumps(data, allow_nan=False)


def test_optimal_trajectories_are_double_integrator_motions_in_si_units(paper):
    """x(k+1) = x(k) + h v(k) + h^2/2 a(k) and v(k+1) = v(k) + h a(k) with h = T / n, in metres and seconds."""
    n = paper.n_intervals
    for case, tr in paper.trajectories.items():
        T = getattr(paper, f"{case}_s")
        assert tr.t[0] == 0.0 and tr.t[-1] == pytest.approx(T, rel=1e-15) and tr.t.size == n + 1
        h = np.diff(tr.t)
        assert np.allclose(h, T / n, rtol=1e-12, atol=0)
        xy_next = tr.xy[:-1] + h[:, None] * tr.v[:-1] + 0.5 * h[:, None] ** 2 * tr.a
        assert np.allclose(tr.xy[1:], xy_next, rtol=0, atol=1e-9)
        assert np.allclose(tr.v[1:], tr.v[:-1] + h[:, None] * tr.a, rtol=0, atol=1e-9)
        assert np.allclose(tr.xy[0], paper.xi0_m, rtol=0, atol=1e-12)  # starts exactly at xi0, at rest
        assert np.allclose(tr.v[0], 0.0, rtol=0, atol=1e-12)


def test_relative_errors_and_ratio_by_hand():
    from nniquad.analysis.bound import BoundResult

    res = BoundResult(vehicle_name="hand", xi0_m=(1.0, 0.0), distance_m=1.0, band_fraction=0.02, band_radius_m=0.02,
                      tilt_limit_deg=30.0, thrust_tilt_limit_deg=60.0, effective_tilt_limit_deg=30.0, a_max_m_s2=1.0,
                      rest_to_rest_s=2.2, enter_band_s=1.5, rest_to_rest_closed_form_s=2.0,
                      enter_band_closed_form_s=1.2, n_intervals=10)
    assert res.rest_to_rest_rel_error == pytest.approx(0.1, rel=1e-12)
    assert res.enter_band_rel_error == pytest.approx(0.25, rel=1e-12)
    assert res.ratio(3.0) == pytest.approx(2.0, rel=1e-15) and res.ratio(None) is None


def test_short_starts_small_tilts_wide_bands_and_few_intervals_are_valid():
    # a 0.5 m start and a 0.5 deg tilt limit: rest to rest over 0.49 m at g tan 0.5 deg
    res = time_optimal_bound(xi0=(0.5, 0.0), tilt_limit_deg=0.5)
    a = 9.81 * math.tan(math.radians(0.5))
    assert res.rest_to_rest_closed_form_s == pytest.approx(2 * math.sqrt(0.49 / a), rel=1e-12)
    assert res.rest_to_rest_s == pytest.approx(res.rest_to_rest_closed_form_s, rel=REL_TOL)
    # a 90 % band: the scaled optimum, 2 sqrt(0.1) ~ 0.63, is far below 1 (no hidden floor on the time)
    wide = time_optimal_bound(band_fraction=0.9)
    assert wide.rest_to_rest_s == pytest.approx(wide.rest_to_rest_closed_form_s, rel=REL_TOL)
    assert wide.enter_band_s == pytest.approx(wide.enter_band_closed_form_s, rel=REL_TOL)
    # two intervals is the smallest transcription: above the continuous optimum, never below
    two = time_optimal_bound(n_intervals=2)
    assert two.n_intervals == 2 and two.rest_to_rest_s >= two.rest_to_rest_closed_form_s * (1 - 1e-7)


def test_the_bound_prints_nothing(capfd):
    time_optimal_bound(n_intervals=20)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


@pytest.mark.parametrize("kwargs, message", [
    ({"xi0": (1.0,)}, "xi0 must be two numbers in m, got 1"),
    ({"xi0": ("a", 1.0)}, "xi0 must be two numbers in m, got ('a', 1.0)"),
    ({"xi0": (float("inf"), 1.0)}, "xi0 must be finite, got (inf, 1.0) m"),
    ({"xi0": (0.0, 0.0)}, "xi0 must not be the origin: there is nothing to settle"),
    ({"tilt_limit_deg": "steep"}, "tilt limit must be a number in deg, got 'steep'"),
    ({"tilt_limit_deg": 90.0}, "tilt limit must be strictly between 0 and 90 deg, got 90.0"),
    ({"band_fraction": 1.0}, "band fraction must be strictly between 0 and 1, got 1.0"),
    ({"band_fraction": 1.5}, "band fraction must be strictly between 0 and 1, got 1.5"),
    ({"n_intervals": 2.5}, "n_intervals must be an integer >= 2, got 2.5"),
    ({"n_intervals": True}, "n_intervals must be an integer >= 2, got True"),
])
def test_bad_options_name_the_problem(kwargs, message):
    with pytest.raises(SimulationError) as info:
        time_optimal_bound(**kwargs)
    assert str(info.value) == message


def test_an_ipopt_failure_reaches_the_user_with_its_status(monkeypatch):
    """IPOPT capped at one iteration really fails; the error names the case and IPOPT's own status."""
    import casadi as ca

    from nniquad.errors import SolverError

    real_solver = ca.Opti.solver

    def one_iteration(self, name, options=None, *rest):
        return real_solver(self, name, {**(options or {}), "ipopt.max_iter": 1}, *rest)

    monkeypatch.setattr(ca.Opti, "solver", one_iteration)
    with pytest.raises(SolverError) as info:
        time_optimal_bound(n_intervals=20)
    assert str(info.value).startswith("IPOPT failed on the rest_to_rest bound problem: Maximum_Iterations_Exceeded (")
