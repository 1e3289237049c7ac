"""``nniquad simulate --reference``: the tracking metrics printed and in the JSON, the run started on the reference,
and one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from nniquad.errors import EXIT_USER_ERROR


def test_simulate_follows_a_waypoint_file(run_cli, tmp_path):
    wp, js = tmp_path / "square.csv", tmp_path / "run.json"
    wp.write_text("t,x,y\n0,0,0\n2,1,0\n3,1,0\n5,1,1\n")
    code, out, err = run_cli("simulate", "--model", "reduced", "--horizon", "7", "--rate", "100", "--reference", str(wp),
                             "--feedforward", "--tracking-window", "1", "7", "--json", str(js))
    assert code == 0, err
    assert "tracking error over [1, 7] s: RMS" in out and "waypoint 1 (1, 0) m, band 0.02 m: at" in out
    assert "verdict" in out and "followed" in out
    data = json.loads(js.read_text())
    m = data["metrics"]
    assert m["tracking_window_s"] == [1.0, 7.0] and 0 < m["tracking_rms_m"] <= m["tracking_max_m"] < 0.02
    assert [a["index"] for a in m["arrivals"]] == [1, 3] and all(a["arrival_s"] is not None for a in m["arrivals"])
    assert data["options"]["feedforward"] is True and data["options"]["reference"]["type"] == "MinimumJerk"
    with np.load(tmp_path / "run.traj.npz") as t:
        assert np.allclose(t["state"][0, :4], 0.0)  # started on the reference (at rest there)


def test_simulate_starts_on_a_circle_with_its_velocity(run_cli, tmp_path):
    js = tmp_path / "run.json"
    code, out, err = run_cli("simulate", "--model", "linear", "--horizon", "2", "--reference", "circle:1.5,6",
                             "--feedforward", "--json", str(js))
    assert code == 0, err
    data = json.loads(js.read_text())
    assert data["options"]["xi0"] == [1.5, 0.0] and data["options"]["v0"] == pytest.approx([0.0, 1.5 * 2 * np.pi / 6])
    assert data["metrics"]["tracking_max_m"] < 1e-6  # linear loop, nominal mass, on the reference: exact


@pytest.mark.parametrize("argv, words", [
    (["--feedforward"], "--feedforward needs --reference"),
    (["--reference", "circle:1"], "circle takes 2 numbers"),
    (["--reference", "figure8:2,1,8", "--feedforward-lead", "0.1"], "--feedforward-lead needs --feedforward"),
    (["--reference", "figure8:2,1,8", "--tracking-window", "50", "60"], "fewer than two samples"),
])
def test_reference_errors_are_one_line(run_cli, argv, words):
    code, out, err = run_cli("simulate", "--model", "linear", "--horizon", "1", *argv)
    assert code == EXIT_USER_ERROR and words in err and "Traceback" not in err
