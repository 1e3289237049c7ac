"""A certificate that states a measurement delay: verify rebuilds the cascade with it, catches a re-signed edit of
``delay_samples`` (top level or in the section), and a run or study beyond the certified delay is flagged
(``simulate``, ``montecarlo``) or refused (``montecarlo --within-certificate``)."""

from __future__ import annotations

import copy
import json

import pytest

from nniquad.certificates import build_certificate, canonical_digest, verify_certificate
from nniquad.errors import NniquadError
from nniquad.model.vehicle import PAPER_VEHICLE as V
from tests.test_certificate import GAINS, INNER, SMALL_BOX

DELAY = 1


@pytest.fixture(scope="module")
def doc(shared_json):
    return shared_json("delay_certificate", lambda: build_certificate(V, GAINS, inner=INNER, model="full",
                                                                      box=SMALL_BOX, tracking=False,
                                                                      grid_points_per_axis=2,
                                                                      delay_samples=DELAY).to_json())


def _resigned(c: dict) -> dict:
    c["digest"]["value"] = canonical_digest(c)
    return c


def _refused(c: dict) -> bool:
    try:
        return not verify_certificate(_resigned(c), simulate=False, fail_fast=True).ok
    except NniquadError:
        return True


def test_the_certificate_states_and_verifies_its_delay(doc):
    assert doc["delay_samples"] == doc["cascade"]["delay_samples"] == DELAY
    names = doc["cascade"]["matrices"]["state_names"]
    assert names[-2 * DELAY:] == ["zcd1_x", "zcd1_y"]
    assert doc["cascade"]["lyapunov"]["subsystems"]["x"]["states"][-1] == "zcd1_x"
    # the Lur'e region with the line full at the start (region.start_vector), re-checked by verify below
    assert doc["cascade"]["region_of_attraction"]["method"] == "lure"
    check = verify_certificate(doc, simulate=False)
    assert check.ok and check["delay_samples"].ok
    assert any(f"exactly {DELAY} samples" in note for note in check.notes)


@pytest.mark.parametrize("edit", ["top", "section", "both", "top_null"])
def test_a_resigned_edit_of_delay_samples_is_caught(doc, edit):
    c = copy.deepcopy(doc)
    if edit in ("top", "both"):
        c["delay_samples"] = DELAY + 1
    if edit in ("section", "both"):  # both: consistent, but the section's Lyapunov blocks are for 1 sample
        c["cascade"]["delay_samples"] = DELAY + 1
    if edit == "top_null":
        del c["delay_samples"]  # an older certificate's form: then it claims no delay, and the section says 1
    assert _refused(c)


def test_a_run_beyond_the_certified_delay_is_flagged(run_cli, doc, tmp_path):
    cert = tmp_path / "cert.json"
    cert.write_text(json.dumps(doc))
    # the section proves exactly DELAY samples: a longer delay is flagged, a shorter one said to be not covered
    for n, flagged, covered in ((DELAY, False, True), (DELAY + 1, True, False), (DELAY - 1, False, False)):
        out_json = tmp_path / f"run{n}.json"
        code, out, _ = run_cli("simulate", "--certificate", str(cert), "--delay-samples", str(n), "--horizon", "0.5",
                               "--json", str(out_json))
        assert code == 0
        assert ("beyond the certified delay" in out) is flagged
        assert ("shorter than the certified" in out) is (not covered and not flagged)
        stated = json.loads(out_json.read_text())
        assert stated["certificate"]["beyond_certified_delay"] is flagged
        assert stated["certificate"]["delay_covered"] is covered
        assert stated["options"].get("delay_samples", 0) == n  # 0, the default, is not written


def test_a_within_certificate_study_beyond_the_certified_delay_is_refused(run_cli, doc, tmp_path):
    cert = tmp_path / "cert.json"
    cert.write_text(json.dumps(doc))
    code, _, err = run_cli("montecarlo", "--certificate", str(cert), "--within-certificate", "--delay-samples",
                           str(DELAY + 1), "--samples", "1", "--workers", "1")
    assert code != 0 and "beyond the certified delay" in err
    code, _, err = run_cli("montecarlo", "--certificate", str(cert), "--within-certificate", "--delay-samples",
                           str(DELAY - 1), "--samples", "1", "--workers", "1")
    assert code != 0 and "not the certified delay" in err and len(err.strip().splitlines()) == 1
