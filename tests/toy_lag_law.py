"""A law added the way every law is added: this one file, one registry entry (the last line), and its tests.

``toy_lag``: the NI structure with a first-order lag as its SNI controller, written in other coordinates than
the paper's law,

.. math:: a_h = -k_p ξ + z/\\hat m, \\qquad z = c_0 w, \\qquad τ \\dot w = ξ - w, \\qquad C(s) = \\frac{c_0}{τ s + 1},

so it *is* the NNI law with ``Γ = c_0/τ`` and ``δ = 1/c_0`` (``z = c_0 w``): the test flies both and compares
(``tests/test_new_law.py``).  Nothing here but the realisation, the sector bound on its own gain and the tuning
coordinates; the start state (``w(0) = ξ(0)``, the law's static state), the exact zero-order hold, the simulator's
expressions, the reduced loop, the LMIs, the certificate and the CLI options come from the interface
(:mod:`nniquad.laws.base`).  In the package it would be ``design/nniquad/laws/toy_lag.py`` and one import line in
``nniquad/laws/__init__.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping, Sequence

from nniquad.laws.base import GainBlock, NILaw, PlainGainBlock, TuningBox, gain_field
from nniquad.laws.search_ranges import GAMMA_DELTA_MIN, KP_RANGE, sector_coordinate_range


@dataclass(frozen=True)
class ToyLagGains(PlainGainBlock):
    """Gains of the ``toy_lag`` law.

    Attributes
    ----------
    kp
        Inner-loop gain [1/s²].
    c0
        DC gain of the controller ``C(0)`` [N/m].
    tau
        Time constant of the lag [s].
    """

    controller: ClassVar[str] = "toy_lag"

    kp: float = gain_field("1/s^2", "inner-loop gain")
    c0: float = gain_field("N/m", "DC gain of the lag controller C(s) = c0/(tau s + 1)")
    tau: float = gain_field("s", "time constant of the lag controller", "τ")


class ToyLagLaw(NILaw):
    """The ``toy_lag`` law (module docstring)."""

    name: ClassVar[str] = "toy_lag"
    title: ClassVar[str] = "velocity-free, a first-order lag c0/(tau s + 1) as the SNI controller (a test law)"
    gains_type: ClassVar[type] = ToyLagGains
    state_names: ClassVar[tuple[str, ...]] = ("zc",)
    state_units: ClassVar[tuple[str, ...]] = ("m",)
    time_scaling: ClassVar[Mapping[str, int]] = {"kp": 2, "c0": 0, "tau": -1}
    gamma_formula: ClassVar[str] = "c0/(m kp)"

    def controller_realisation(self, p: Mapping[str, Any]) -> tuple[list, list, list, list]:
        tau = p["tau"]
        return [[-1 / tau]], [[1 / tau]], [[p["c0"]]], [[0]]

    def sector_limit(self, gains: GainBlock, m: float, kp: float, gamma: float) -> tuple[str, float]:
        return "c0_max", float(gamma) * float(m) * float(kp)

    def coordinates(self, law_class: str | None) -> tuple[str, ...]:
        return ("ln kp", "u = ln(gamma_max/gamma), gamma = c0/(m kp)", "ln(1/tau)")

    def box(self, law_class: str | None, limits: TuningBox) -> tuple[list[float], list[float]]:
        q1 = sector_coordinate_range(self.check_class(law_class))
        return ([math.log(KP_RANGE[0]), q1[0], math.log(GAMMA_DELTA_MIN)],
                [math.log(limits.kp_max), q1[1], math.log(limits.pole_max)])

    def decode(self, q: Sequence[float], m: float, gamma_max: float, law_class: str | None) -> ToyLagGains:
        kp = math.exp(q[0])
        paper = self.check_class(law_class) == "paper"
        gamma = gamma_max * math.exp(-q[1]) if paper else 1.0 / (1.0 + math.exp(q[1]))
        return ToyLagGains(kp=kp, c0=gamma * m * kp, tau=math.exp(-q[2]))

    def encode(self, gains: Any, m: float, gamma_max: float, law_class: str | None) -> list[float]:
        if not isinstance(gains, ToyLagGains):
            raise ValueError(f"{type(gains).__name__} is not a gain block of the {self.name!r} law")
        gamma = gains.c0 / (m * gains.kp)
        q1 = math.log(gamma_max / gamma) if self.check_class(law_class) == "paper" else math.log(1.0 / gamma - 1.0)
        return [math.log(gains.kp), q1, -math.log(gains.tau)]


#: The law.  A law in the package registers itself at import (``NNI = register(NNILaw())``); the tests register
#: this one for their own duration (``tests/test_new_law.py``), so that no other test sees a fifth law.
TOY_LAG = ToyLagLaw()
