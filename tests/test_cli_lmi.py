"""``nniquad lmi``: table, JSON, and one-line errors for bad gains."""

from __future__ import annotations

import json

import pytest


def test_lmi_default_run_writes_json(run_cli, tmp_path):
    out_json = tmp_path / "lmi.json"
    code, out, err = run_cli("lmi", "--json", str(out_json))
    assert code == 0, err
    for name in ("ni_lemma_paper[plant]", "ni_lemma_dissipation[controller]", "closed_loop_decay",
                 "robust_mass_decay[pdlf]", "region_of_attraction[x]"):
        assert name in out
    data = json.loads(out_json.read_text())
    assert data["gains"] == {"kp": 5.0, "kpy": 5.0, "Gamma": 160.0, "delta": 0.6}
    by_name = {e["name"]: e for e in data["lmis"]}
    for entry in data["lmis"]:
        assert {"name", "feasible", "status", "residuals", "matrices"} <= set(entry)
    assert by_name["ni_lemma_paper[plant]"]["status"] == "infeasible"
    P = by_name["ni_lemma_dissipation[plant]"]["matrices"]["P"]
    assert [P[0][0], P[0][1], P[1][1]] == pytest.approx([2.5, 0.0, 0.5], abs=1e-6)
    assert by_name["closed_loop_decay"]["feasible"] is True
    assert data["frequency"]["x"]["predicted_stable"] is True


def test_lmi_two_axes_and_mass_range(run_cli):
    code, out, err = run_cli("lmi", "--kpy", "4", "--mass-range", "0.3", "1.0")
    assert code == 0, err
    assert "ni_lemma_dissipation[plant_y]" in out and "region_of_attraction[y]" in out
    line = next(l for l in out.splitlines() if l.startswith("robust_mass_decay[pdlf]"))
    assert " NO " in line  # 0.3 kg < 1/(kp delta) = 0.4167 kg: unstable at the low mass


@pytest.mark.parametrize(
    "argv, word",
    [
        (["--kp", "nan"], "kp"),
        (["--Gamma", "-1"], "Gamma"),
        (["--delta", "abc"], "delta"),
        (["--kpy", "0"], "kpy"),
        (["--mass-range", "1.0", "0.5"], "mass-range"),
        (["--tilt-limit", "inf"], "tilt"),
    ],
)
def test_bad_gains_exit_2_one_line(run_cli, argv, word):
    code, out, err = run_cli("lmi", *argv)
    assert code == 2
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1 and word in err
