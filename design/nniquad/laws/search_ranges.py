"""The tuner's coordinate ranges that every law shares (each law's box is in its own module).

The gains are searched in logarithmic coordinates, and the sector constant of a
law of the NI structure in one of two coordinates that build the class into the
box: ``u = ln(γ_max/γ)`` for the ``paper`` class (the sector bound is ``u >= 0``)
and ``v = ln(1/γ - 1)`` for the ``cascade`` class (``γ < 1`` is built in; ``v``
spreads the designs near ``γ = 1``, where a filtered PD with a small
``k_p τ_f/k_d`` lives: ``m kp δ - 1 = k_p τ_f/k_d`` for its NNI image).
"""

from __future__ import annotations

import math

__all__ = ["KP_RANGE", "U_RANGE", "V_RANGE", "GAMMA_DELTA_MIN", "CASCADE_GAMMA_CAP", "PD_ZETA_RANGE",
           "sector_coordinate_range"]

#: Bounds of the inner-loop (position) gain kp [1/s²] that do not depend on the vehicle.
KP_RANGE: tuple[float, float] = (0.5, 2000.0)
#: Range of ``u = ln(γ_max/γ)`` of the paper class: from the sector bound (0) to γ = γ_max e⁻⁴.
U_RANGE: tuple[float, float] = (0.0, 4.0)
#: Smallest controller pole searched [1/s] (the NNI law's Γδ).
GAMMA_DELTA_MIN: float = 0.05
#: Largest sector constant the cascade class searches: γ <= 0.995 (the static stiffness at least 0.5 % of the
#: inner loop's; below it a wind offset grows without bound).
CASCADE_GAMMA_CAP: float = 0.995
#: Range of ``v = ln(1/γ - 1)`` of the cascade class: from the cap above to the paper class's u = 4 at γ_max 0.8.
V_RANGE: tuple[float, float] = (math.log(1.0 / CASCADE_GAMMA_CAP - 1.0), math.log(math.exp(U_RANGE[1]) / 0.8 - 1.0))
#: Damping ratio ``k_d / (2 √k_p)`` of a PD law on the double integrator: the search range.
PD_ZETA_RANGE: tuple[float, float] = (0.3, 2.0)


def sector_coordinate_range(law_class: str | None) -> tuple[float, float]:
    """The range of the sector coordinate of a class: :data:`U_RANGE` (``paper``) or :data:`V_RANGE` (``cascade``).

    Parameters
    ----------
    law_class
        ``"paper"`` or ``"cascade"``.
    """
    return U_RANGE if law_class == "paper" else V_RANGE
