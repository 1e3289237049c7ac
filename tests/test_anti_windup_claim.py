"""The anti-windup keeps the saturated take-over start within the claim of an integral certificate.

The committed ``nni_i`` certificate (``tests/data/nni_i_small_box_certificate.json``) states a Lur'e-Postnikov region
``{V <= c}`` (:mod:`nniquad.analysis.cascade.region`) of its sampled cascade with back-calculation anti-windup, and
that the 2.5 m start is inside it.  Here the family is rebuilt from the certificate's design as ``verify`` rebuilds it
(:func:`nniquad.analysis.cascade.family.family_cached`) at the nominal point and corners of the certified box, and
the **nonlinear** sampled loop ``x⁺ = A0 x + B sat_L(K x)`` (21 states, the norm limit of the two-axis command) is
run from the take-over start.  Along the trajectory ``V`` is evaluated from the stated matrices with plain numpy,
nothing of the LMI solver: the start is inside, ``V`` decreases by at least what the region proves at every step,
so the trajectory stays inside, and the state converges.  The start's command is computed by hand
(``k_p`` per metre: the controller starts at 0) and is deep in the saturation, so the dead zone and the anti-windup act.

Without the anti-windup rows (``A0 - E K``, ``B + E``) the stated region no longer proves a decrease at any point
(the region's own numpy check fails), and the integrator winds: the loop stays saturated far longer.  Measured, not
asserted: from these starts (2.5 m and the stated reach) the trajectory without anti-windup happens to stay inside
``{V <= c}`` with ``V`` decreasing too, so along them the claim does not separate the two loops; only the proof does.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from nniquad.analysis.cascade.box import POINT_NAMES, ParameterBox
from nniquad.analysis.cascade.family import family_cached, mode_transform, subsystem_blocks
from nniquad.analysis.cascade.recheck import stated_delay
from nniquad.analysis.cascade.region import HORIZONTAL, LureRegion, axis_states, huber, lure_check, start_vector
from nniquad.analysis.cascade.section import anti_windup_matrix
from nniquad.certificates import read_certificate
from nniquad.config import XI0_M

CERT_PATH = Path(__file__).resolve().parent / "data" / "nni_i_small_box_certificate.json"
#: Samples run: 30 s at 100 Hz, about 20 times the region's slowest time constant 1/decay of the linear loop.
STEPS = 3000
#: Start directions: the configured start's, and three others (the norm limit couples the axes off the axes).
ANGLES = (math.atan2(XI0_M[1], XI0_M[0]), 0.0, math.pi / 2, 3 * math.pi / 4)


@pytest.fixture(scope="module")
def setup():
    """The certificate, its family at the nominal point and four corners of its box, and its stated region."""
    cert = read_certificate(CERT_PATH)
    sec = cert.cascade
    box = ParameterBox.from_json(sec["box"])
    lo, hi = box.bounds()
    odd = np.arange(6) % 2 == 1
    points = np.array([np.ones(6), lo, hi, np.where(odd, lo, hi), np.where(odd, hi, lo)])
    fam = family_cached(cert.vehicle, cert.gains, cert.inner_loop, points, cert.tilt_limit_deg,
                        float(sec["rate_hz"]), stated_delay(sec))
    subs = sec["lyapunov"]["subsystems"]
    dims = {a: tuple(POINT_NAMES.index(d) for d in subs[a]["dims"]) for a in subs}
    region = LureRegion.from_json(sec["region_of_attraction"]["lure"], dims, axis_states(fam))
    # the anti-windup rows of the whole state (the controller's states end it: no delay line here)
    n, n_k = len(fam.state_names), fam.A_k.shape[0]
    E = np.zeros((n, 2))
    E[n - n_k:] = anti_windup_matrix(fam)["E_anti_windup"]
    np.testing.assert_allclose(E[n - n_k:], sec["matrices"]["E_anti_windup"], rtol=1e-12)
    assert np.any(E) and fam.delay_samples == 0
    return cert, box, fam, region, E


def _starts(fam, r):
    """The take-over starts at distance ``r`` in each of :data:`ANGLES` (rows), from the axes' start vectors."""
    Tm, _ = mode_transform(fam.state_names, fam.frame)
    blocks = subsystem_blocks(fam.state_names)
    v = {a: Tm[blocks[a]].T @ start_vector(fam, a) for a in HORIZONTAL}
    return np.array([r * (math.cos(t) * v["x"] + math.sin(t) * v["y"]) for t in ANGLES])


def _lyapunov(box, fam, region, i):
    """``(V, xᵀPx)`` of the stated region at point ``i``, on rows of full states."""
    Tm, _ = mode_transform(fam.state_names, fam.frame)
    blocks = subsystem_blocks(fam.state_names)
    L = float(np.broadcast_to(fam.accel_limit, (len(fam),))[i])
    parts = {a: region.at(box, fam.points[i:i + 1], a) for a in HORIZONTAL}
    mu = float(parts["x"][2][0])

    def lyap(X):
        quad = sum(np.einsum("mi,ij,mj->m", X @ Tm[blocks[a]].T, parts[a][0][0], X @ Tm[blocks[a]].T)
                   for a in HORIZONTAL)
        return quad + 2.0 * mu * huber(np.linalg.norm(X @ fam.K.T, axis=1) / L), quad

    return lyap


def _run(fam, i, X, E=None):
    """The nonlinear sampled loop at point ``i`` from the rows of ``X``: the states ``(STEPS + 1, M, n)`` and, per
    step, which commands exceed the limit ``(STEPS, M)``; ``E`` given: its anti-windup rows removed."""
    A0, B, K = fam.A0[i], fam.B[i], fam.K
    if E is not None:
        A0, B = A0 - E @ K, B + E
    L = float(np.broadcast_to(fam.accel_limit, (len(fam),))[i])
    xs, sat = [X], []
    for _ in range(STEPS):
        a = X @ K.T
        norm = np.linalg.norm(a, axis=1, keepdims=True)
        sat.append(norm[:, 0] > L)
        X = X @ A0.T + a * np.minimum(1.0, L / np.maximum(norm, 1e-300)) @ B.T
        xs.append(X)
    return np.array(xs), np.array(sat)


@pytest.mark.parametrize("distance", ["start", "reach"])
def test_the_saturated_take_over_start_stays_within_the_certified_region_and_converges(setup, distance):
    cert, box, fam, region, _ = setup
    c = region.level
    r = cert.start["distance_m"] if distance == "start" else cert.cascade["region_of_attraction"]["max_displacement_m"]
    assert cert.start["methods"]["cascade"]["inside"] is True and r <= cert.start["methods"]["cascade"]["reach_m"]
    # the stated start: every controller state at 0 (NNI and integrator), so the command is -kp xi by hand
    assert cert.law_class["integral_action"]["start"] == "controller state 0; integrator q = 0"
    names = list(fam.state_names)
    ctrl = [names.index(s) for s in cert.gains.law.sim_state_names]
    for i in range(len(fam)):
        X0 = _starts(fam, r)
        np.testing.assert_allclose(X0[:, [names.index("x"), names.index("y")]],
                                   r * np.array([[math.cos(t), math.sin(t)] for t in ANGLES]), atol=1e-12)
        assert not np.any(X0[:, ctrl])
        L = float(np.broadcast_to(fam.accel_limit, (len(fam),))[i])
        np.testing.assert_allclose(np.linalg.norm(X0 @ fam.K.T, axis=1), cert.gains.kp * r, rtol=1e-9)
        assert cert.gains.kp * r > 5 * L  # deep in the saturation at take-over
        xs, sat = _run(fam, i, X0)
        lyap = _lyapunov(box, fam, region, i)
        V, quad = (np.array(v) for v in zip(*(lyap(x) for x in xs)))  # (STEPS + 1, M)
        assert np.all(V[0] <= c)  # the start is inside, as stated
        assert np.all(V <= c)  # and so is the whole trajectory
        # the decrease the region proves, V(x⁺) - V(x) <= -(1 - rho²) x'Px, to rounding
        assert np.all(np.diff(V, axis=0) <= -(1.0 - region.rho ** 2) * quad[:-1] + 1e-12 * c)
        assert np.all(np.linalg.norm(xs[-1], axis=1) <= 1e-9 * np.linalg.norm(X0, axis=1))
        assert np.all(sat[0]) and np.all(sat.sum(axis=0) > 10)  # the anti-windup acts over many samples
        assert not np.any(sat[-1])


def test_without_the_anti_windup_the_region_proves_nothing_and_the_integrator_winds(setup):
    cert, box, fam, region, E = setup
    windup = replace(fam, A0=fam.A0 - E @ fam.K, B=fam.B + E)  # the same linear loop A_d, no back-calculation
    assert np.allclose(windup.A0 + windup.B @ fam.K, fam.A_d, rtol=0, atol=1e-12)
    assert lure_check(region, box, fam).ok
    bad = lure_check(region, box, windup)
    # the decrease form is indefinite at every point, far beyond its rounding bound
    assert bad.decrease > 1e6 * bad.decrease_bound
    assert all(len(bad.failing[a]) == len(fam) for a in HORIZONTAL)
    # the integrator winds: from the stated start the command stays saturated far longer
    X0 = _starts(fam, cert.start["distance_m"])
    for i in range(len(fam)):
        n_aw = _run(fam, i, X0)[1].sum(axis=0)
        n_windup = _run(fam, i, X0, E)[1].sum(axis=0)
        assert np.all(n_windup >= 1.5 * n_aw)
