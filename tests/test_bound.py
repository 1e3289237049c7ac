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
