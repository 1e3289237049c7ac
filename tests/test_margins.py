"""Margins: closed forms, python-control's own methods, Padé against the exact sampled loop."""

from __future__ import annotations

import json
import math

import control as ct
import numpy as np
import pytest

from nniquad.analysis.linearised_cascade import linearise_cascade
from nniquad.analysis.margins import cascade_margins, frequency_grid, frequency_response, loop_margins
from nniquad.analysis.sampled import sampled_gain_interval
from nniquad.config import REQUIRED_GM_DB, REQUIRED_PM_DEG
from nniquad.laws.nni import Gains
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.model.vehicle import PAPER_VEHICLE

GAINS = Gains(kp=13.148341568334407, Gamma=25.27258951977003, delta=0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56021438245625, attitude_zeta=1.1320049751084362,
                       attitude_accel_limit_rad_s2=31.13986455385077)


def test_third_order_loop_closed_form():
    # L = k/(s (s+1)(s+2)): phase -180 deg at w = sqrt(2), |L| = k/6 there, so GM = 6/k exactly
    k = 2.0
    L = ct.ss(ct.tf([k], [1, 3, 2, 0]))
    m = loop_margins(L, "test", "continuous", None)
    assert m.gm_db == pytest.approx(20 * math.log10(6 / k), abs=1e-6)
    assert m.w_pc_rad_s == pytest.approx(math.sqrt(2), rel=1e-6)
    gm, pm, _, _, wgc, _ = ct.stability_margins(ct.tf([k], [1, 3, 2, 0]))  # python-control's exact method
    assert m.pm_deg == pytest.approx(pm, abs=1e-6)
    assert m.w_gc_rad_s == pytest.approx(wgc, rel=1e-6)
    assert m.gm_lower_db == -math.inf
    w = frequency_grid(L)
    dm, _, dpm = ct.disk_margins(L, w, skew=0.0)
    assert m.disk_alpha == pytest.approx(dm, rel=1e-9)
    assert m.disk_pm_deg == pytest.approx(dpm, rel=1e-9)


@pytest.mark.parametrize("k, stable", [(5.9, True), (6.1, False)])
def test_disk_margin_applies_only_to_a_stable_loop(k, stable):
    # L = k/(s (s+1)(s+2)): 1 + L = 0 is s^3 + 3 s^2 + 2 s + k, stable iff 0 < k < 6 (Routh)
    m = loop_margins(ct.ss(ct.tf([k], [1, 3, 2, 0])), "test", "continuous", None)
    assert m.stable is stable
    d = json.loads(json.dumps(m.to_json(), allow_nan=False))
    if stable:
        assert 0 < m.disk_alpha < 2 and m.disk_gm_db > 0 and m.disk_pm_deg > 0
        assert "disk alpha" in str(m)
    else:
        assert (m.disk_alpha, m.disk_gm_db, m.disk_pm_deg) == (None, None, None)
        assert (d["disk_alpha"], d["disk_gm_db"], d["disk_pm_deg"]) == (None, None, None)
        assert "n/a" in str(m) and not m.meets_requirement


def test_frequency_response_matches_python_control():
    L = ct.ss(ct.tf([3.0, 1.0], [1, 2, 5, 1]))
    w = np.geomspace(0.1, 10, 7)
    np.testing.assert_allclose(frequency_response(L, w), L(1j * w), rtol=1e-12)
    Ld = ct.c2d(L, 0.05)
    np.testing.assert_allclose(frequency_response(Ld, w), Ld(np.exp(1j * w * 0.05)), rtol=1e-10)


@pytest.fixture(scope="module")
def cascade():
    return linearise_cascade(PAPER_VEHICLE, GAINS, INNER)


def test_pade_margins_agree_with_the_exact_sampled_loop(cascade):
    for rate in (100.0, 400.0):
        m = cascade_margins(cascade, rate)
        assert m["horizontal"].pm_deg == pytest.approx(m["horizontal_zoh"].pm_deg, abs=0.2)
        assert m["horizontal"].gm_db == pytest.approx(m["horizontal_zoh"].gm_db, abs=0.3)
        assert m["horizontal"].disk_alpha == pytest.approx(m["horizontal_zoh"].disk_alpha, rel=1e-2)
    cont = cascade_margins(cascade, None)["horizontal"]
    fast = cascade_margins(cascade, 1e4)["horizontal_zoh"]
    assert fast.pm_deg == pytest.approx(cont.pm_deg, abs=0.05)  # sampling delay vanishes


def test_attitude_gain_interval_agrees_with_the_exact_sampled_bisection(cascade):
    pade = cascade_margins(cascade, 100.0)["attitude"]
    k_lo, k_hi = sampled_gain_interval(cascade, 100.0)
    assert 20 * math.log10(k_lo) == pytest.approx(pade.gm_lower_db, abs=0.2)
    assert (k_hi == math.inf) == (pade.gm_db == math.inf)


def test_gain_interval_ends_are_stability_boundaries(cascade):
    cl = cascade.closed_loop(None)
    m = loop_margins(cl.loop("horizontal"), "horizontal", "continuous", None)
    b, c = cl.breaks["horizontal"]
    k = 10 ** (m.gm_db / 20)
    A0 = cl.A - np.outer(b, c)
    assert np.max(np.linalg.eigvals(A0 + k * 0.999 * np.outer(b, c)).real) < 0
    assert np.max(np.linalg.eigvals(A0 + k * 1.001 * np.outer(b, c)).real) > 0


def test_requirement_and_json(cascade):
    m = cascade_margins(cascade, 100.0)
    for v in m.values():
        d = json.loads(json.dumps(v.to_json(), allow_nan=False))
        expect = (v.stable and v.gm_db >= REQUIRED_GM_DB and v.gm_lower_db <= -REQUIRED_GM_DB
                  and v.pm_deg >= REQUIRED_PM_DEG)
        assert d["meets_requirement"] is expect
    # the committed design's attitude loop has a few degrees of phase margin: it fails
    assert m["attitude"].pm_deg < REQUIRED_PM_DEG and not m["attitude"].meets_requirement


def _control_crossings(resp, w, dt):
    gm, pm, _, wpc, wgc, _ = ct.stability_margins(ct.frd(resp, w, dt=dt), returnall=True)
    return [np.atleast_1d(np.asarray(v, float)) for v in (gm, pm, wpc, wgc)]


@pytest.mark.parametrize("rate", [None, 100.0, 400.0])
def test_frd_crossings_reproduce_python_control_on_every_loop(cascade, rate):
    """frd_crossings (scipy) against python-control's stability_margins on the same frequency-response data.

    Every loop of the margins section: both Padé break points (continuous) and the exact
    discrete-time loop; the crossings must be the same ones, at the same frequencies.
    """
    from nniquad.analysis.margins import frd_crossings
    from nniquad.analysis.sampled import sampled_cascade

    cl = cascade.closed_loop(rate)
    loops = [cl.loop_system(bp) for bp in ("horizontal", "attitude")]
    if rate is not None:
        loops.append(sampled_cascade(cascade, rate).loop_system("horizontal"))
    crossings = 0
    for L in loops:
        w = frequency_grid(L)
        resp = frequency_response(L, w)
        mine = frd_crossings(resp, w)
        ref = _control_crossings(resp, w, L.dt or 0)
        for got, want in zip(mine, ref):
            assert got.shape == want.shape
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
        crossings += mine[0].size + mine[1].size
    assert crossings >= 2 * len(loops) - 1  # the loops do cross (not a comparison of empty arrays)


def test_frd_crossings_on_closed_forms():
    """L = k/(s (s+1)(s+2)): one phase crossover at sqrt(2) with GM = 6/k; no crossing on a loop below 0 dB."""
    from nniquad.analysis.margins import frd_crossings

    k = 2.0
    L = ct.ss(ct.tf([k], [1, 3, 2, 0]))
    w = frequency_grid(L)
    gm, pm, wpc, wgc = frd_crossings(frequency_response(L, w), w)
    assert wpc == pytest.approx([math.sqrt(2)], rel=1e-6) and gm == pytest.approx([6 / k], rel=1e-6)
    assert wgc.size == 1 and pm.size == 1
    small = ct.ss(ct.tf([0.01], [1, 1]))  # |L| < 1 everywhere, phase above -90 deg: no crossover at all
    w = frequency_grid(small)
    gm, pm, wpc, wgc = frd_crossings(frequency_response(small, w), w)
    assert gm.size == pm.size == wpc.size == wgc.size == 0
    m = loop_margins(small, "test", "continuous", None)
    assert m.gm_db == math.inf and m.pm_deg == math.inf


def test_loop_system_is_the_python_control_loop(cascade):
    """The matrices handed to the margins are python-control's loop (same A, B, C, D, dt and poles)."""
    from nniquad.analysis.sampled import sampled_cascade

    cl = cascade.closed_loop(100.0)
    sd = sampled_cascade(cascade, 100.0)
    for mine, theirs in ((cl.loop_system("attitude"), cl.loop("attitude")),
                         (sd.loop_system("horizontal"), sd.loop("horizontal"))):
        assert isinstance(theirs, ct.StateSpace)
        for a, b in ((mine.A, theirs.A), (mine.B, theirs.B), (mine.C, theirs.C), (mine.D, theirs.D)):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
        assert (mine.dt or 0) == theirs.dt
        np.testing.assert_allclose(np.sort_complex(mine.poles()), np.sort_complex(theirs.poles()), rtol=1e-12)
