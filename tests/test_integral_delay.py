"""An integral law with a measurement delay line: the cascade's anti-windup sits on the law's integrator, not on
the delay line.

The sampled loop ``x⁺ = A0 x + B sat(K x)`` carries the anti-windup as ``A0 + E K``, ``B = Γ - E``
(:func:`nniquad.analysis.cascade.family.sampled_family`).  With ``N`` samples of delay the state gains the
delay line after the controller's states; the anti-windup must stay ``T/k_s`` on each axis's ``q`` (``k_s``
the base law's static stiffness per unit mass, here from :meth:`ControlLaw.static_stiffness`, a DC gain of the
realisation, not the Cramer's-rule expression the law feeds its anti-windup with) and zero on the line.
"""

from __future__ import annotations

import numpy as np

from nniquad.analysis.cascade.family import sampled_family
from nniquad.analysis.cascade.section import anti_windup_matrix
from tests.test_integral_cascade import GAINS_I, LAW
from tests.test_robust_cascade import GAINS, INNER, RATE, TILT, V

DELAY = 2


def test_the_anti_windup_acts_on_the_integrator_and_not_on_the_delay_line():
    fam = sampled_family(V, GAINS_I, INNER, np.ones((1, 6)), tilt_limit_deg=TILT, rate_hz=RATE, delay_samples=DELAY)
    names = list(fam.state_names)
    k_s = GAINS.law.static_stiffness(GAINS, V.m)[0] / V.m  # the base law's stiffness per unit mass
    T = 1.0 / RATE
    E = np.zeros((len(names), 2))
    E[names.index("zci_x"), 0] = E[names.index("zci_y"), 1] = T / k_s
    # Γ of the plant's rows, no input on the controller or the delay line: what is left of B is -E
    n_p = fam.Gam.shape[1]
    expected_B = -E
    expected_B[:n_p] = fam.Gam[0]
    np.testing.assert_allclose(fam.B[0], expected_B, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(fam.A0[0], fam.A_d[0] - fam.B[0] @ fam.K, rtol=1e-9, atol=1e-9)
    # the section's stated matrix: the controller's states only, the same as without the delay line
    stated = np.asarray(anti_windup_matrix(fam)["E_anti_windup"])
    undelayed = sampled_family(V, GAINS_I, INNER, np.ones((1, 6)), tilt_limit_deg=TILT, rate_hz=RATE)
    np.testing.assert_allclose(stated, np.asarray(anti_windup_matrix(undelayed)["E_anti_windup"]), rtol=1e-12)
    rows = [names.index(s) for s in LAW.sim_state_names]
    np.testing.assert_allclose(stated, E[rows], rtol=1e-9)
