"""``nniquad prove``: table, JSON, Markdown, --only, --strict, errors."""

from __future__ import annotations

import json


def test_prove_only_writes_json_and_markdown(run_cli, tmp_path):
    j, md = tmp_path / "a.json", tmp_path / "a.md"
    code, out, err = run_cli("prove", "--only", "delta-min,steady-state", "--json", str(j), "--markdown", str(md))
    assert code == 0
    assert "delta-min" in out and "holds" in out
    data = json.loads(j.read_text())
    assert [c["id"] for c in data["claims"]] == ["delta-min", "steady-state"]
    assert {"id", "paper_ref", "verdict", "statement", "evidence", "counterexample", "correction", "method"} <= set(
        data["claims"][0])
    assert "### delta-min" in md.read_text()


def test_prove_strict_exit_status(run_cli):
    assert run_cli("prove", "--only", "delta-min", "--strict")[0] == 0
    code, out, _ = run_cli("prove", "--only", "sni-ws-nni-equivalence", "--strict")
    assert code == 1 and "fails" in out
    assert run_cli("prove", "--only", "sni-ws-nni-equivalence")[0] == 0


def test_prove_unknown_id_is_a_one_line_error(run_cli):
    code, out, err = run_cli("prove", "--only", "no-such-claim")
    assert code == 2
    assert "unknown claim id" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_prove_list(run_cli):
    code, out, _ = run_cli("prove", "--list")
    assert code == 0 and "simulation-claim" in out.split()


def test_prove_workers(run_cli):
    code, out, _ = run_cli("prove", "--only", "delta-min,simulation-claim", "--workers", "2")
    assert code == 0 and "delta-min" in out and "simulation-claim" in out
    code, _, err = run_cli("prove", "--workers", "0")
    assert code == 2 and "--workers" in err and len(err.strip().splitlines()) == 1
