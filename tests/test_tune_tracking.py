"""The tracking objective of ``tune --reference``: a better follower than the settling objective's design, flown by
a hand-written integrator; the settling objective unchanged without a reference; the objective stated; one-line
errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nniquad.config import TILT_LIMIT_DEG
from nniquad.control.reference_files import parse_reference
from nniquad.errors import EXIT_USER_ERROR, NniquadError
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.tuning.tune import TuneOptions, tune
from nniquad.tuning.tune_options import default_tracking_window

#: One xdist worker runs this module (its fixtures run two quick tunes).
pytestmark = pytest.mark.xdist_group("test_tune_tracking")

SPEC = "figure8:2,1,8"
GOLDEN = Path(__file__).parent / "data" / "tune_quick_reduced_seed0.json"


@pytest.fixture(scope="module")
def settling_design():
    return tune(V, TuneOptions(model="reduced", roa_radius_m=0.0, budget="quick"))


@pytest.fixture(scope="module")
def tracking_cli(tmp_path_factory):
    """``nniquad tune --reference SPEC`` (quick, reduced, no feedforward: with it the reduced loop follows exactly)."""
    from nniquad.cli.main import main
    import contextlib
    import io

    js = tmp_path_factory.mktemp("tune") / "tune.json"
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = main(["tune", "--model", "reduced", "--budget", "quick", "--roa-radius", "0", "--reference", SPEC,
                     "--json", str(js)])
    return code, out.getvalue(), json.loads(js.read_text())


def _tracking_rms_scipy(gains: dict, window: tuple[float, float]) -> float:
    """The reduced NNI loop following the reference, written out by hand and integrated with scipy (not CasADi):
    ``ξ̈ = sat(-k_p e + z/m)``, ``ż = -Γδ z + Γ e``, ``e = ξ - ξ_d``, started on the reference with its velocity
    and ``z = 0`` (the law at rest for a zero error)."""
    ref = parse_reference(SPEC)
    m, kp, G, d = V.m, gains["kp"], gains["Gamma"], gains["delta"]
    a_max = V.g * math.tan(math.radians(TILT_LIMIT_DEG))

    def f(t, x):
        e = x[0:2] - ref.position(t)[0]
        a = -kp * e + x[4:6] / m
        n = np.linalg.norm(a)
        a = a * (a_max / n) if n > a_max else a
        return np.concatenate([x[2:4], a, -G * d * x[4:6] + G * e])

    pos, vel, _ = ref.sample(0.0)
    t = np.linspace(window[0], window[1], 1601)
    sol = solve_ivp(f, (0.0, window[1]), np.concatenate([pos[0], vel[0], [0.0, 0.0]]), method="LSODA",
                    t_eval=t, rtol=1e-9, atol=1e-11)
    err2 = np.sum((sol.y[0:2].T - ref.position(t)) ** 2, axis=1)
    return math.sqrt(np.trapezoid(err2, t) / (t[-1] - t[0]))


def test_tracking_design_follows_better_than_the_settling_design(settling_design, tracking_cli):
    code, out, data = tracking_cli
    assert code == 0
    window = default_tracking_window(parse_reference(SPEC))
    assert window == (8.0, 16.0)  # the second period of the 8 s figure-eight
    tracked = _tracking_rms_scipy(data["gains"], window)
    settled = _tracking_rms_scipy(settling_design.gains.as_dict(), window)
    assert tracked < settled  # strictly: the objective changed the design (equal gains would fly equal errors)
    # the tuner's own number agrees with the hand-written loop
    assert data["tracking"]["tracking_rms_m"] == pytest.approx(tracked, rel=0.02)
    # and the design still meets the settling objective's constraints
    assert data["settling_s"] < data["horizon_s"] and data["sector"]["gamma"] <= 0.8 * (1 + 1e-12)


def test_the_objective_is_stated(tracking_cli):
    code, out, data = tracking_cli
    stated = f"objective: RMS tracking error on {SPEC} without feedforward over [8, 16] s"
    assert out.splitlines()[0].startswith(stated) and "subject to: settles from the start" in out
    assert data["objective_statement"].startswith(stated)
    rms = data["tracking"]["tracking_rms_m"]
    assert f"tracking RMS over [8, 16] s" in out and data["tracking"]["tracking_window_s"] == [8.0, 16.0]
    assert 0 < rms <= data["tracking"]["tracking_max_m"]
    assert data["options"]["reference"]["spec"] == SPEC and data["options"]["feedforward"] is False


def test_without_a_reference_the_settling_objective_is_unchanged(settling_design):
    golden = json.loads(GOLDEN.read_text())
    assert settling_design.gains.as_dict() == pytest.approx(golden["gains"], rel=1e-9)
    assert settling_design.settling_s == pytest.approx(golden["settling_s"], rel=1e-9)
    data = settling_design.to_json()
    assert "tracking" not in data and "reference" not in data["options"]
    assert data["objective_statement"].startswith("objective: minimise the settling time")


@pytest.mark.parametrize("argv, words", [
    (["--reference", "figure8:2,1"], "figure8 takes 3 numbers"),
    (["--feedforward"], "--feedforward needs --reference"),
    (["--tracking-window", "1", "2"], "--tracking-window needs --reference"),
    (["--reference", SPEC, "--tracking-window", "5", "3"], "tracking window must satisfy 0 <= T0 < T1"),
])
def test_bad_tracking_options_are_one_line(run_cli, argv, words):
    code, out, err = run_cli("tune", "--model", "reduced", "--budget", "quick", *argv)
    assert code == EXIT_USER_ERROR and words in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_tracking_options_need_a_reference():
    with pytest.raises(NniquadError, match="feedforward needs a reference"):
        TuneOptions(feedforward=True)
