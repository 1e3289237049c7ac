"""The filtered-derivative PD law is the NNI law: the gain maps both ways.

With the project's conventions (per axis ``a_h = -k_p' ξ + z/m̂``,
``z' = -Γδ z + Γ ξ``, the controller's nominal mass ``m̂``), the PD law with a
dirty derivative of the measured position,

.. math:: a_h = -k_p ξ - k_d \\frac{s}{τ_f s + 1} ξ
              = -\\Big(k_p + \\frac{k_d}{τ_f}\\Big) ξ + \\frac{k_d/τ_f^2}{s + 1/τ_f} ξ,

is the NNI law with

.. math:: k_p' = k_p + k_d/τ_f,\\qquad Γ = \\hat m k_d/τ_f^2,\\qquad δ = τ_f/(\\hat m k_d).

State by state: the filter state ``d`` (``d' = (ξ - d)/τ_f``, ``v̂ = (ξ - d)/τ_f``)
is ``z = d/δ = \\hat m k_d d/τ_f``, so the two laws give the same run from the
same start once the NNI state starts at ``z(0) = d(0)/δ``
(:func:`nni_start_state`; the PD filter starts at ``d(0) = ξ(0)``).  The
map back exists exactly when ``\\hat m k_p' δ > 1`` (then ``k_p = k_p' - 1/(\\hat m δ)
> 0``), which is the Routh condition of the reduced NNI loop: every stable
NNI gain set is a filtered PD and every filtered PD is a stable NNI gain set.

The paper's sector bound ``δ ≥ 1/(γ \\hat m k_p')`` reads, under the map,
``(k_p τ_f/k_d + 1) γ ≥ 1``: the smallest γ of a filtered PD is
``k_d/(k_p τ_f + k_d)`` (:func:`filtered_pd_gamma`), always below 1, and it
satisfies the bound with ``γ_max`` iff ``k_p τ_f/k_d ≥ 1/γ_max - 1`` (0.25 at the
paper's γ = 0.8).  ``nniquad.proofs.extensions`` checks all of this with sympy.
"""

from __future__ import annotations

from typing import Sequence

from nniquad.control.law_classes import SECTOR_RTOL
from nniquad.control.gains import Gains, PDFilteredGains, positive_gain
from nniquad.errors import GainError

__all__ = ["nni_from_filtered_pd", "filtered_pd_from_nni", "nni_start_state", "filtered_pd_gamma",
           "filtered_pd_in_sector"]


def nni_from_filtered_pd(pd: PDFilteredGains, m_hat: float) -> Gains:
    """The NNI gain set that is the filtered-derivative PD law ``pd`` (module docstring).

    Parameters
    ----------
    pd
        The filtered PD gains ``k_p`` [1/s²], ``k_d`` [1/s], ``τ_f`` [s].
    m_hat
        The controller's nominal mass [kg] (the NNI output is divided by it).

    Returns
    -------
    Gains
        ``kp = k_p + k_d/τ_f``, ``Gamma = m̂ k_d/τ_f²``, ``delta = τ_f/(m̂ k_d)``.
    """
    if not isinstance(pd, PDFilteredGains):
        raise GainError(f"a filtered-derivative PD gain block is needed, got {type(pd).__name__}")
    m = positive_gain("nominal mass", m_hat)
    return Gains(kp=pd.kp + pd.kd / pd.tau_f, Gamma=m * pd.kd / pd.tau_f**2, delta=pd.tau_f / (m * pd.kd))


def filtered_pd_from_nni(gains: Gains, m_hat: float) -> PDFilteredGains:
    """The filtered-derivative PD law that is the NNI gain set ``gains`` (inverse of :func:`nni_from_filtered_pd`).

    Parameters
    ----------
    gains
        NNI gains with equal axes.
    m_hat
        The controller's nominal mass [kg].

    Returns
    -------
    PDFilteredGains
        ``τ_f = 1/(Γδ)``, ``k_d = 1/(m̂ Γ δ²)``, ``k_p = kp - 1/(m̂ δ)``.

    Raises
    ------
    GainError
        Unequal axis gains, or ``m̂ kp δ <= 1`` (the reduced loop is not stable and
        no filtered PD with ``k_p > 0`` is this law).
    """
    if not isinstance(gains, Gains):
        raise GainError(f"an NNI gain block is needed, got {type(gains).__name__}")
    if gains.kpy is not None and gains.kpy != gains.kp:
        raise GainError("a filtered PD has one gain for both axes: kpy must equal kp")
    m = positive_gain("nominal mass", m_hat)
    kp_static = gains.kp - 1.0 / (m * gains.delta)
    if not kp_static > 0:
        raise GainError(f"m kp delta = {m * gains.kp * gains.delta:.6g} <= 1: no filtered PD is this NNI law "
                        "(its reduced loop is not stable)")
    return PDFilteredGains(kp=kp_static, kd=1.0 / (m * gains.Gamma * gains.delta**2),
                           tau_f=1.0 / (gains.Gamma * gains.delta))


def nni_start_state(pd: PDFilteredGains, m_hat: float, d0_m: Sequence[float]) -> tuple[float, float]:
    """The NNI controller state ``z(0) = d(0)/δ`` [N] that starts as the PD filter state ``d(0)`` does.

    Parameters
    ----------
    pd
        The filtered PD gains.
    m_hat
        The controller's nominal mass [kg].
    d0_m
        The filter state at the start, per axis [m] (the simulator starts it at ``ξ(0)``).
    """
    delta = nni_from_filtered_pd(pd, m_hat).delta
    return (float(d0_m[0]) / delta, float(d0_m[1]) / delta)


def filtered_pd_gamma(pd: PDFilteredGains) -> float:
    """Smallest γ with which the NNI image of ``pd`` satisfies the sector bound: ``k_d/(k_p τ_f + k_d)`` (< 1).

    Independent of the mass (``1/(m̂ k_p' δ)`` with the map of the module docstring).

    Parameters
    ----------
    pd
        The filtered PD gains.
    """
    return pd.kd / (pd.kp * pd.tau_f + pd.kd)


def filtered_pd_in_sector(pd: PDFilteredGains, gamma_max: float) -> bool:
    """Whether the image of ``pd`` satisfies the sector bound with ``γ_max``: ``(k_p τ_f/k_d + 1) γ_max >= 1``.

    Parameters
    ----------
    pd
        The filtered PD gains.
    gamma_max
        The sector constant, in (0, 1).
    """
    return (pd.kp * pd.tau_f / pd.kd + 1.0) * float(gamma_max) >= 1.0 - SECTOR_RTOL
