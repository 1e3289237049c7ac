"""Sampled-data loops: exact ZOH discretisation and a discrete-time Lyapunov certificate.

Setting
-------
The position is measured at the control rate ``f_s = 1/T`` (sampled, held
between samples: zero-order hold).  The attitude loop, the motors and the
altitude loop are **continuous** (they run on the flight controller's fast
inner rate, modelled as continuous); only the position measurement and the NNI
controller are sampled.

The NNI controller in discrete time
-----------------------------------
``C(s) = Γ/(s + Γδ)`` (state ``z' = -Γδ z + Γ ξ``) with its input held over
each period has the exact ZOH discretisation

.. math:: z_{k+1} = e^{-\\Gamma\\delta T} z_k + \\frac{1 - e^{-\\Gamma\\delta T}}{\\delta}\\, \\xi_k,
          \\qquad a_k = -k_p \\xi_k + z_k/\\hat m,

and ``a_k`` is held over ``[kT, (k+1)T)`` (variant ``"discrete"``, what
:mod:`nniquad.control.discrete` runs and ``nniquad export`` writes).  The
simulator's ``sample_hold`` today keeps the controller continuous and feeds it
the held measurement (variant ``"held"``): the same ``z_k`` at the samples, but
``a_h`` follows ``z(t)`` between them.  Both are offered.

The plant with its inputs held
------------------------------
``x' = A x + B u`` with ``u`` constant over a period is exactly
``x_{k+1} = Φ x_k + Γ_d u_k`` with ``[[Φ, Γ_d], [0, I]] = expm([[A, B], [0, 0]] T)``
(:func:`zoh`, scipy ``expm``), so the discrete closed loop agrees with the
sampled-data loop at every sample instant (no approximation).

Certificate
-----------
:func:`discrete_lyapunov_decay` (in :mod:`nniquad.analysis.sampled_lyapunov`, re-exported here) finds ``P > 0`` with ``A_dᵀ P A_d ⪯ ρ² P`` for
the smallest ``ρ`` it can (:func:`best_decay`, cvxpy + Clarabel), so that
``‖x_k‖_P <= ρ^k ‖x_0‖_P``: a decay rate ``-ln ρ / T`` [1/s].  The result is
re-checked with numpy: the eigenvalues of ``P`` and ``ρ_P = ‖P^{1/2} A_d P^{-1/2}‖₂``
(the exact contraction factor of ``P``), which must not exceed the stated ``ρ``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg as sla

from nniquad.analysis.linearised_cascade import CONTROLLER_VARIANTS, LinearCascade, linearise
from nniquad.analysis.loops import LinearSystem

# the Lyapunov certificate of a sampled loop, re-exported (its callers import it from here)
from nniquad.analysis.sampled_lyapunov import (  # noqa: F401
    DiscreteDecay,
    best_decay,
    conditioning_transform,
    contraction,
    discrete_lyapunov_decay,
    solve_with_clarabel,
)
from nniquad.config import CONTROL_RATE_HZ
from nniquad.errors import CascadeError
from nniquad.sim import SimOptions, SimParams

__all__ = [
    "zoh",
    "nni_zoh_closed_form",
    "SampledLoop",
    "sampled_cascade",
    "sampled_reduced_loop",
    "sampled_loop_from_blocks",
    "contraction",
    "sampled_gain_interval",
    "DiscreteDecay",
    "discrete_lyapunov_decay",
    "best_decay",
    "solve_with_clarabel",
]


def control_period(rate_hz: float) -> float:
    if isinstance(rate_hz, bool) or not isinstance(rate_hz, (int, float, np.floating)) or not math.isfinite(rate_hz) \
            or rate_hz <= 0:
        raise CascadeError(f"sample rate must be a finite positive number of Hz, got {rate_hz!r}")
    return 1.0 / float(rate_hz)


def zoh(A: np.ndarray, B: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of ``x' = A x + B u`` with ``u`` held over ``T``.

    Parameters
    ----------
    A, B
        Continuous-time matrices.
    T
        Sample period [s].

    Returns
    -------
    Phi, Gamma_d : ndarray
        ``x_{k+1} = Phi x_k + Gamma_d u_k`` (the blocks of ``expm([[A, B], [0, 0]] T)``).
    """
    A, B = np.atleast_2d(np.asarray(A, float)), np.asarray(B, float).reshape(np.shape(A)[0], -1)
    n, m = A.shape[0], B.shape[1]
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = sla.expm(M * T)
    return E[:n, :n], E[:n, n:]


def nni_zoh_closed_form(Gamma: float, delta: float, T: float) -> tuple[float, float]:
    """The ZOH discretisation of ``C(s) = Γ/(s + Γδ)`` in closed form: ``(e^{-ΓδT}, (1 - e^{-ΓδT})/δ)``."""
    a = math.exp(-Gamma * delta * T)
    return a, -math.expm1(-Gamma * delta * T) / delta


@dataclass(frozen=True)
class SampledLoop:
    """A discrete-time closed loop ``x_{k+1} = A_d x_k`` with its break points.

    Attributes
    ----------
    A_d : ndarray
        Closed-loop transition matrix over one period.
    T
        Sample period [s].
    state_names
        Names of the states (at the sample instants).
    variant
        ``"discrete"`` or ``"held"`` (module docstring).
    breaks
        ``name -> (b, c)``: a scalar discrete-time signal ``v_k = c x_k`` fed back through ``b``.
    """

    A_d: np.ndarray
    T: float
    state_names: tuple[str, ...]
    variant: str
    breaks: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.T

    @property
    def spectral_radius(self) -> float:
        """``max |eig(A_d)|``: the loop is stable iff it is below 1."""
        return float(np.max(np.abs(np.linalg.eigvals(self.A_d))))

    @property
    def stable(self) -> bool:
        return self.spectral_radius < 1.0

    @property
    def decay_rate(self) -> float:
        """``-ln(spectral radius)/T`` [1/s]: the continuous-time equivalent of the slowest mode's decay."""
        return -math.log(self.spectral_radius) / self.T

    def loop_system(self, name: str) -> LinearSystem:
        """Discrete loop transfer function ``L(z) = -c (zI - A_0)^{-1} b`` (``dt = T``) as a :class:`LinearSystem`."""
        if name not in self.breaks:
            raise CascadeError(f"unknown break point {name!r} of the sampled loop "
                               f"(choose one of {', '.join(self.breaks)})")
        b, c = self.breaks[name]
        return LinearSystem(self.A_d - np.outer(b, c), b.reshape(-1, 1), -c.reshape(1, -1), np.zeros((1, 1)), self.T)

    def loop(self, name: str):
        """:meth:`loop_system` as a python-control ``StateSpace`` (``dt = T``)."""
        return self.loop_system(name).to_control()

    def lyapunov(self, **kwargs: Any) -> "DiscreteDecay":
        """:func:`discrete_lyapunov_decay` of this loop."""
        return discrete_lyapunov_decay(self.A_d, self.T, **kwargs)


def _plant_with_torque_gain(cascade: LinearCascade, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Plant matrices with the roll-torque command multiplied by ``k``."""
    b = cascade.torque_injection()
    t_p = cascade.torque_plant_row()
    _, t_a = cascade.torque_rows()
    return cascade.A_p + (k - 1.0) * np.outer(b, t_p), cascade.B_p + (k - 1.0) * np.outer(b, t_a)


def sampled_cascade(cascade: LinearCascade, rate_hz: float = CONTROL_RATE_HZ, *, variant: str = "discrete",
                    torque_gain: float = 1.0) -> SampledLoop:
    """The exact sampled-data cascade at the sample instants.

    Parameters
    ----------
    cascade
        Linearised cascade (:func:`nniquad.analysis.linearised_cascade.linearise_cascade`).
    rate_hz
        Position sample rate = control rate [Hz].
    variant
        ``"discrete"``: plant discretised with ``a_h`` held, controller by its
        exact ZOH equivalent.  ``"held"``: plant and continuous controller
        discretised together with the measurement held.
    torque_gain
        Factor on the (continuous) roll-torque command; 1 is nominal
        (:func:`sampled_gain_interval` varies it).

    Returns
    -------
    SampledLoop
        States: the plant, then the controller.  Break point ``"horizontal"``
        (the discrete command ``a_h[k]``, x axis; ``"discrete"`` only) and
        ``"measurement"`` (the sampled ``ξ_x[k]``).
    """
    A_p, B_p = _plant_with_torque_gain(cascade, torque_gain)
    return sampled_loop_from_blocks(A_p, B_p, cascade.C_p, cascade.A_k, cascade.B_k, cascade.C_k, cascade.D_k,
                                    cascade.plant_states + cascade.controller_states, rate_hz, variant)


def sampled_loop_from_blocks(A_p: np.ndarray, B_p: np.ndarray, C_p: np.ndarray, A_k: np.ndarray, B_k: np.ndarray,
                             C_k: np.ndarray, D_k: np.ndarray, names: tuple[str, ...], rate_hz: float,
                             variant: str = "discrete") -> SampledLoop:
    """The sampled loop of a plant ``(A_p, B_p, C_p)`` (input ``a_h``) and controller ``(A_k, B_k, C_k, D_k)``.

    See :func:`sampled_cascade` for the two controller variants and the break points.
    """
    if variant not in CONTROLLER_VARIANTS:
        raise CascadeError(f"unknown controller variant {variant!r} (choose one of {', '.join(CONTROLLER_VARIANTS)})")
    T = control_period(rate_hz)
    n_p, n_k = A_p.shape[0], A_k.shape[0]
    n_y = C_p.shape[0]
    breaks: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if variant == "discrete":
        Phi, Gam = zoh(A_p, B_p, T)
        A_kd, B_kd = zoh(A_k, B_k, T)
        ah = np.hstack([D_k @ C_p, C_k])            # a_h[k] from the state at k
        A_d = np.zeros((n_p + n_k, n_p + n_k))
        A_d[:n_p, :n_p] = Phi
        A_d[:n_p] += Gam @ ah
        A_d[n_p:, :n_p] = B_kd @ C_p
        A_d[n_p:, n_p:] = A_kd
        b = np.concatenate([Gam[:, 0], np.zeros(n_k)])
        breaks["horizontal"] = (b, ah[0].copy())
        bm = np.concatenate([Gam @ D_k[:, 0], B_kd[:, 0]])
    else:
        Ac = np.block([[A_p, B_p @ C_k], [np.zeros((n_k, n_p)), A_k]])
        Bc = np.vstack([B_p @ D_k, B_k])
        Phi, Gam = zoh(Ac, Bc, T)
        A_d = Phi + Gam @ np.hstack([C_p, np.zeros((n_y, n_k))])
        bm = Gam[:, 0]
    cm = np.concatenate([C_p[0], np.zeros(n_k)])
    breaks["measurement"] = (bm, cm)
    return SampledLoop(A_d, T, tuple(names), variant, breaks)


def sampled_reduced_loop(vehicle, gains, rate_hz: float = CONTROL_RATE_HZ, *, variant: str = "discrete") -> SampledLoop:
    """The paper's reduced loop (``ξ'' = a_h``, both axes) sampled at ``rate_hz``, from the ``linear`` model.

    The plant and the controller are the Jacobian blocks of the simulator's
    ``linear`` model (:func:`nniquad.analysis.linearised_cascade.linearise`), split as in
    the cascade; the sampling is as in :func:`sampled_cascade`.
    """

    p = SimParams.from_options(vehicle, gains, SimOptions(model="linear", sample_hold=True))
    lin = linearise("linear", p)
    ctrl = p.gains.law.sim_state_names
    ik, ih = lin.index(*ctrl), lin.index("held_x", "held_y")
    plant = ("x", "x_dot", "y", "y_dot")
    ip = lin.index(*plant)
    A_k, B_k, C_k, D_k = lin.J[np.ix_(ik, ik)], lin.J[np.ix_(ik, ih)], lin.Y[:, ik], lin.Y[:, ih]
    # the plant sees the controller only through a_h (as in the cascade)
    B_p = lin.J[np.ix_(ip, ik + ih)] @ np.linalg.pinv(np.hstack([C_k, D_k]))
    C_p = np.zeros((2, len(plant)))
    C_p[0, plant.index("x")] = C_p[1, plant.index("y")] = 1.0
    return sampled_loop_from_blocks(lin.J[np.ix_(ip, ip)], B_p, C_p, A_k, B_k, C_k, D_k, plant + ctrl,
                                    rate_hz, variant)


def sampled_gain_interval(cascade: LinearCascade, rate_hz: float = CONTROL_RATE_HZ, *, variant: str = "discrete",
                          k_max: float = 1e5, rtol: float = 1e-6) -> tuple[float, float]:
    """Exact gain interval of the continuous roll-torque command inside the sampled-data loop.

    The factor ``k`` on the roll-torque command is swept by bisection on the
    spectral radius of :func:`sampled_cascade` (``torque_gain=k``): this is the
    exact sampled-data gain margin, with no Padé model of the sampling.

    Returns
    -------
    k_lo, k_hi : float
        Stable for ``k_lo < k < k_hi`` around 1 (``k_hi = inf`` if stable up to ``k_max``).
    """
    def stable(k: float) -> bool:
        return sampled_cascade(cascade, rate_hz, variant=variant, torque_gain=k).stable

    if not stable(1.0):
        return math.nan, math.nan

    def bisect(lo: float, hi: float) -> float:  # stable at lo, unstable at hi (log-scale bisection)
        while abs(math.log(hi / lo)) > rtol:
            mid = math.sqrt(lo * hi)
            lo, hi = (mid, hi) if stable(mid) else (lo, mid)
        return math.sqrt(lo * hi)

    # scan a log grid first: the stable set need not be an interval far from k = 1
    def first_unstable(end: float, none_found: float) -> float:
        """Walk a geometric grid from the nominal gain 1 towards ``end``; bisect the first stability loss."""
        prev = 1.0
        for k in np.geomspace(1.0, end, 101)[1:]:
            if not stable(float(k)):
                return bisect(prev, float(k))
            prev = float(k)
        return none_found

    return first_unstable(1.0 / k_max, 0.0), first_unstable(k_max, math.inf)
