"""One honest word "certified": the start per method, "recomputed" apart from "requirement met", what certify
prints, margins with digits and the failing one named, and a mistyped option's nearest neighbour.

The references: the committed certificates' own sections (each region's stated reach, which ``verify`` recomputes)
and the start's distance by hand; hand-built margins (only the phase margin failing, only the gain margin, both);
printed margin strings parsed back; the parser's own option list.
"""

from __future__ import annotations

import copy
import math
import re
from pathlib import Path

import pytest

from nniquad.certificates import Certificate, canonical_digest, read_certificate, verify_certificate
from nniquad.certificates.start import CASCADE, REDUCED_LOOP, lure_fallback_reason, start_methods, start_section
from nniquad.cli.commands.certify_command import summary_lines
from nniquad.errors import NniquadError
from nniquad.format import failing_margins, margin_text, margin_verdict

DATA = Path(__file__).resolve().parents[1] / "notebooks" / "data"
COMMITTED = sorted(DATA.glob("*_certificate.json"))
SNI2 = DATA / "sni2_cascade_certificate.json"


def _distance(cert: Certificate) -> float:
    return math.sqrt(cert.xi0_m[0] ** 2 + cert.xi0_m[1] ** 2)


@pytest.mark.parametrize("path", COMMITTED, ids=lambda p: p.stem)
def test_the_start_per_method_is_each_regions_stated_reach(path):
    """Each method's reach is its own section's value; inside is the start's distance against it; the every-method
    verdict is the conjunction (the committed certificates predate the section: it is derived)."""
    cert = read_certificate(path)
    st = start_methods(cert)
    want = {REDUCED_LOOP: cert.region_of_attraction["max_displacement_m"]}
    if cert.cascade is not None:
        want[CASCADE] = cert.cascade["region_of_attraction"]["max_displacement_m"]
    assert {k: m["reach_m"] for k, m in st["methods"].items()} == want
    assert {k: m["inside"] for k, m in st["methods"].items()} == {k: _distance(cert) <= r for k, r in want.items()}
    assert st["every_method"] is all(_distance(cert) <= r for r in want.values())
    assert st["methods"][CASCADE]["method"] == cert.cascade["region_of_attraction"]["method"]
    # the old top-level word meant the reduced loop only, and still reads so
    assert cert.start is None and cert.start_certified is (_distance(cert) <= want[REDUCED_LOOP])


def test_the_sni2_certificate_states_two_different_verdicts_and_why():
    cert = read_certificate(SNI2)
    st = start_methods(cert)["methods"]
    assert st[REDUCED_LOOP]["inside"] and not st[CASCADE]["inside"] and st[CASCADE]["method"] == "linear_zone"
    why = lure_fallback_reason(cert)
    assert why is not None and "not tried" in why and "sni2" in why
    assert lure_fallback_reason(read_certificate(DATA / "full_model_certificate.json")) is None  # a Lur'e region


_INSIDE = re.compile(r"^start (\S+ m) (inside|NOT inside) the (\w+) region \((\w+)\): reach (\S+) m$")
_EVERY = re.compile(r"^start certified by every method \(([^)]*)\): (yes|no)$")


@pytest.mark.parametrize("path", COMMITTED, ids=lambda p: p.stem)
def test_certify_prints_no_two_lines_that_contradict_each_other(path):
    """Every line certify prints about the start: one per method, and a verdict that is their conjunction over the
    methods it names; no other line speaks of the start being certified; a linear-zone fallback says why."""
    assert_no_contradiction(summary_lines(read_certificate(path)), read_certificate(path))


def assert_no_contradiction(lines: list[str], cert: Certificate) -> None:
    """What ``certify`` printed about the start (``lines``, without their indent) agrees with itself and with the
    certificate: one line per method, one verdict that is their conjunction, no other line on the start being
    certified, and the Lur'e fallback's reason exactly when the cascade region is the linear zone."""
    per = {m.group(3): m.group(2) == "inside" for m in map(_INSIDE.match, lines) if m}
    every = [m for m in map(_EVERY.match, lines) if m]
    assert per == {k: m["inside"] for k, m in start_methods(cert)["methods"].items()}
    assert len(every) == 1 and every[0].group(1).split(", ") == list(per)
    assert (every[0].group(2) == "yes") is all(per.values())
    talk = [line for line in lines if "certified" in line and "start" in line]
    assert talk == [every[0].group(0)], talk  # the old "start state certified: yes" line is gone
    fallback = [line for line in lines if "linear zone, not the Lur'e region" in line]
    assert len(fallback) == (cert.cascade is not None and cert.cascade["region_of_attraction"]["method"] == "linear_zone")


# ----------------------------------------------------------------------------- verify: a certificate with a start


@pytest.fixture(scope="module")
def sni2_with_start() -> dict:
    """The committed sni2 certificate as it is written now: with its 'start' section and the every-method word."""
    doc = read_certificate(SNI2).to_json()
    doc["start"] = start_section(doc["xi0_m"], doc["region_of_attraction"], doc["cascade"])
    doc["start_certified"] = doc["start"]["every_method"]
    doc["digest"]["value"] = canonical_digest(doc)
    return doc


@pytest.fixture(scope="module")
def fast_cascade():
    """The cascade section's own re-check (seconds, tested in test_robust_cascade and test_cascade_check) stubbed: one
    row, the one whose requirement verify states (the start in the cascade's region)."""
    import nniquad.certificates.recheck_reduced_loop as recheck
    from nniquad.certificates.verify import clear_cache

    clear_cache()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(recheck, "check_cascade_rows", lambda *a, **k: [("start certified", True, "stub", ())])
        yield
    clear_cache()  # verify's in-process cache holds the stub's rows: no later test may read them


@pytest.fixture(scope="module")
def verified(sni2_with_start, fast_cascade):
    return verify_certificate(sni2_with_start, simulate=False)


def test_a_certificate_with_a_start_section_verifies_and_its_word_is_the_weakest(sni2_with_start, verified):
    assert verified.ok, verified.table()
    assert sni2_with_start["start_certified"] is False  # the cascade region does not cover the start
    start = verified["start"]
    assert start.ok and start.requirement_met is False
    assert not any("from before the per-method" in n for n in verified.notes)


def _leaves(node, path=()):
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _leaves(v, path + (k,))
    else:
        yield path


def _refused(doc: dict) -> bool:
    doc["digest"]["value"] = canonical_digest(doc)
    try:
        return not verify_certificate(doc, simulate=False, fail_fast=True).ok
    except NniquadError:
        return True


def test_every_re_signed_edit_of_the_start_is_refused(sni2_with_start, fast_cascade):
    """Each leaf of 'start' and the top-level word, changed alone and re-signed (the tamper loop's recipe)."""
    for path in [("start_certified",)] + [("start",) + p for p in _leaves(sni2_with_start["start"])]:
        doc = copy.deepcopy(sni2_with_start)
        node = doc
        for key in path[:-1]:
            node = node[key]
        v = node[path[-1]]
        node[path[-1]] = (not v if isinstance(v, bool) else v + "x" if isinstance(v, str) else v * 1.001 + 1e-6)
        assert _refused(doc), path
    doc = copy.deepcopy(sni2_with_start)
    doc["start"]["methods"].pop(CASCADE)  # a method left out: the word would then cover only the reduced loop
    doc["start"]["every_method"] = doc["start_certified"] = True
    assert _refused(doc)


def test_verify_separates_recomputed_from_requirement_met(verified):
    rows = {c["name"]: c for c in verified.to_json()["checks"]}
    assert all("requirement_met" in c for c in rows.values())
    assert rows["margins"]["ok"] is True and rows["margins"]["requirement_met"] is False
    assert rows["margins"]["requirement_met"] is read_certificate(SNI2).margins["meets_requirement"]
    assert rows["cascade.start certified"]["ok"] is True and rows["cascade.start certified"]["requirement_met"] is False
    assert rows["digest"]["requirement_met"] is None
    table = verified.table().splitlines()
    assert table[0].split()[:4] == ["check", "result", "requirement", "method"]
    margins_row = next(line for line in table if line.startswith("margins "))
    assert margins_row.split()[1:3] == ["pass", "NOT"]  # pass (recomputed), requirement NOT MET
    # the detail: margins to three digits with units, the failing margin named
    assert "FAILS PM >= 45 deg" in margins_row and not re.search(r"\d\.\d{5,}", margins_row)


# ----------------------------------------------------------------------------- margins


@pytest.mark.parametrize("gm, low, pm, stable, failing", [
    (11.2216981362, "-inf", 41.8, True, ["PM"]),
    (4.5, "-inf", 47.3, True, ["GM"]),
    ("inf", -3.1, 47.3, True, ["GM"]),        # the lower gain margin too close to 0 dB
    (4.5, "-inf", 30.0, True, ["GM", "PM"]),
    (11.2, "-inf", 47.3, True, []),
    ("nan", "nan", "nan", True, ["GM", "PM"]),
])
def test_the_failing_margin_is_named(gm, low, pm, stable, failing):
    assert failing_margins(gm, low, pm, 6.0, 45.0) == failing
    verdict = margin_verdict({"gm_db": gm, "gm_lower_db": low, "pm_deg": pm, "stable": stable}, 6.0, 45.0)
    named = {"GM": "GM >= 6 dB", "PM": "PM >= 45 deg"}
    if failing:
        assert verdict == "FAILS " + " and ".join(named[f] for f in failing)
    else:
        assert verdict == "meets GM >= 6 dB, PM >= 45 deg"
    assert margin_verdict({"gm_db": 11.2, "gm_lower_db": "-inf", "pm_deg": 47.3, "stable": False}, 6, 45) == \
        "FAILS: unstable loop"


def test_a_margin_string_parses_back_to_three_digits():
    gm, low, pm = 11.221698136295279, -16.43951, 47.2849
    text = margin_text(gm, low, pm)
    m = re.fullmatch(r"GM \+(\S+)/(\S+) dB, PM (\S+) deg", text)
    assert m, text
    for shown, value in zip(map(float, m.groups()), (gm, low, pm)):
        assert abs(shown - value) <= 0.5 * 10 ** (math.floor(math.log10(abs(value))) - 2)
    assert margin_text("inf", "-inf", 30.0) == "GM +inf/-inf dB, PM 30 deg"
    assert margin_text("nan", "nan", -2.8189) == "GM n/a, PM -2.82 deg"  # an unstable loop has no gain margin


# ----------------------------------------------------------------------------- a mistyped option


@pytest.mark.parametrize("argv, nearest", [
    (["certify", "--out", "c.json", "--boxscale", "0.1"], "--box-scale"),
    (["verify", "--fail-fat", "c.json"], "--fail-fast"),
    (["certfy", "--out", "c.json"], "certify"),
    (["certify", "--controller", "sni3", "--out", "c.json"], "sni2"),
])
def test_a_mistyped_option_gets_the_nearest_one_in_one_line(run_cli, tmp_path, monkeypatch, argv, nearest):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(*argv)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert f"did you mean '{nearest}'?" in err
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_nothing_close_gets_no_suggestion(run_cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli("verify", "--zzzzzzzz", "c.json")
    assert code == 2 and "did you mean" not in err and len(err.strip().splitlines()) == 1


# ----------------------------------------------------------------------------- progress


def test_certify_steps_rise_from_zero_to_a_hundred():
    """Progress.steps on a plain stream: one line per step at once (no rate limit), rising percentages; the job
    reports 100 % at its end (certify_steps counts the certificate's steps, and the tune's when it ran)."""
    import io

    from nniquad.jobs.certify import certify_steps
    from nniquad.progress import Progress

    for tuned in (False, True):
        stream = io.StringIO()
        p = Progress("certify", stream=stream, every_s=1e9)
        if tuned:
            p.message("tuning")
        step = p.steps(certify_steps(tuned), done=int(tuned))
        for k in range(certify_steps(tuned) - int(tuned)):
            step(f"step {k}")
        p(1.0, "done")
        got = [int(v) for v in re.findall(r"\] +(\d+) %", stream.getvalue())]
        total = certify_steps(tuned)
        assert got == [round(100 * k / total) for k in range(total)] + [100], stream.getvalue()


# ----------------------------------------------------------------------------- the report's side-by-side table


def test_the_paper_law_beside_the_certified_law():
    """Each figure computed by code: the certified column is its certificate's sections, the paper column the paper's
    gains computed with the certificate's settings (its DC loop gain is 1/(m kp delta) by hand; its cascade region is
    said to be not computed, never certified)."""
    from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS
    from nniquad.laws.nni import PAPER_GAINS
    from nniquad.reporting.comparison import certificate_column, comparison_table, computed_column

    cert = read_certificate(DATA / "full_model_certificate.json")
    certified = certificate_column(cert)
    assert certified["runs"]["full"]["settling_s"] == cert.performance["full"]["settling_s"]
    assert certified["regions"][CASCADE]["reach_m"] == cert.cascade["region_of_attraction"]["max_displacement_m"]
    assert certified["regions"][REDUCED_LOOP]["reach_m"] == cert.certified_reach_m
    paper = computed_column(cert.vehicle, PAPER_GAINS, DEFAULT_INNER_LOOP_GAINS, tilt_limit_deg=cert.tilt_limit_deg,
                            gamma_max=cert.sector["gamma_max"], xi0=cert.xi0_m, rate_hz=100.0, horizon_s=20.0)
    assert paper["gamma"] == pytest.approx(1 / (cert.vehicle.m * PAPER_GAINS.kp * PAPER_GAINS.delta), rel=1e-12)
    reach = paper["regions"][REDUCED_LOOP]["reach_m"]
    assert reach > 0 and paper["regions"][REDUCED_LOOP]["inside"] is (_distance(cert) <= reach)
    assert paper["regions"][CASCADE] == {"method": "not computed", "reach_m": None, "inside": None}
    header, rows = comparison_table({"paper's law": paper, "certified law": certified})
    assert header == ["figure", "paper's law", "certified law"] and all(len(r) == 3 for r in rows)
    cells = {r[0]: r[1:] for r in rows}
    assert cells["certified reach, cascade region"][0] == "not computed"
    assert cells["certified reach, cascade region"][1].startswith("2.82 m (lure): start inside")
    assert "FAILS PM >= 45 deg" in cells["margins (horizontal)"][1]
