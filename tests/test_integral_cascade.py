"""The cascade certificate of a law with integral action: its sampled loop, its region, its certificate.

The sampled loop of :func:`nniquad.analysis.cascade.family.sampled_family` (``x⁺ = A0 x + B sat(K x)``, the
anti-windup in ``A0`` and ``B``) is compared with one step of the simulator's generated discrete law in a saturated
state: the family comes from the hover Jacobians and ``scipy.linalg.expm``, the simulator's step from the law's own
sample update with its excess recomputed in CasADi, so the two share no code but the law's equations.
"""

from __future__ import annotations

import math

import numpy as np

from nniquad.analysis.cascade.family import sampled_family
from nniquad.analysis.linearised_cascade import hover_params
from nniquad.laws import integral_variant
from nniquad.sim import EXO_FIELDS, initial_state, state_names
from nniquad.sim.models import step_function
from tests.test_robust_cascade import GAINS, INNER, RATE, TILT, V

#: The test design of tests/test_robust_cascade.py with an integral gain (its zero at 0.05 of sqrt(kp)).
LAW = integral_variant(GAINS.law)
GAINS_I = LAW.with_ki(GAINS, 0.05 * GAINS.kp ** 1.5)


def test_the_family_loop_is_one_step_of_the_simulators_discrete_law_in_saturation():
    T = 1.0 / RATE
    fam = sampled_family(V, GAINS_I, INNER, np.ones((1, 6)), tilt_limit_deg=TILT, rate_hz=RATE)
    names = list(fam.state_names)
    n_k = len(LAW.sim_state_names)
    # a saturated state: 3 m out, the controller wound up at an arbitrary state
    xi = np.array([3.0, -2.0])
    xc = np.array([0.7, -0.4, 1.3, 0.9])  # zc_x, zc_y, zci_x, zci_y
    x = np.zeros(len(names))
    x[names.index("x")], x[names.index("y")] = xi
    x[[names.index(s) for s in LAW.sim_state_names]] = xc
    a = fam.K @ x
    L = float(fam.accel_limit[0])
    assert np.linalg.norm(a) > 5 * L  # deep in the saturation
    sat = a * min(1.0, L / np.linalg.norm(a))
    family_next = (fam.A0[0] @ x + fam.B[0] @ sat)[-n_k:]
    # the simulator: the full model at hover, the position held over the period that ends, a later sample
    params = hover_params(V, GAINS_I, INNER, TILT, None).with_(run={"sample_hold": 1.0, "discrete": 1.0,
                                                                    "sample_period": T})
    snames = state_names("full", LAW.name)
    X = np.array(initial_state("full", params, (0.0, 0.0)), float)
    w_hover = math.sqrt(V.m * V.g / (4.0 * V.b))
    for k in range(1, 5):
        X[snames.index(f"w{k}")] = w_hover
    X[snames.index("held_x")], X[snames.index("held_y")] = xi
    X[[snames.index(s) for s in LAW.sim_state_names]] = xc
    e = np.zeros(len(EXO_FIELDS))
    e[2] = 2.0  # a later sample instant: the controller advances one period on the held value
    X_next = np.asarray(step_function("full", LAW.name)(X, e, params.vector())).ravel()
    sim_next = X_next[[snames.index(s) for s in LAW.sim_state_names]]
    # the same state order on both sides (the family's controller states are the law's, interleaved)
    assert names[-n_k:] == list(LAW.sim_state_names)
    np.testing.assert_allclose(family_next, sim_next, rtol=1e-9, atol=1e-12)
    # and the anti-windup is what makes them agree: without it the integrator would gain T ξ, not T (ξ - ψ/kp)
    q_no_aw = xc[2:] + T * xi
    assert np.min(np.abs(sim_next[2:] - q_no_aw)) > 1e-3 * T
