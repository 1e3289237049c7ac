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
:func:`discrete_lyapunov_decay` finds ``P > 0`` with ``A_dᵀ P A_d ⪯ ρ² P`` for
the smallest ``ρ`` it can (:func:`best_decay`, cvxpy + Clarabel), so that
``‖x_k‖_P <= ρ^k ‖x_0‖_P``: a decay rate ``-ln ρ / T`` [1/s].  The result is
re-checked with numpy: the eigenvalues of ``P`` and ``ρ_P = ‖P^{1/2} A_d P^{-1/2}‖₂``
(the exact contraction factor of ``P``), which must not exceed the stated ``ρ``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable, TypeVar

import numpy as np
import scipy.linalg as sla

from nniquad.analysis.cascade import CONTROLLER_VARIANTS, LinearCascade
from nniquad.analysis.loops import LinearSystem
from nniquad.config import CONTROL_RATE_HZ
from nniquad.errors import CascadeError, SolverError

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


def _period(rate_hz: float) -> float:
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
    controller
        ``"discrete"`` or ``"held"`` (module docstring).
    breaks
        ``name -> (b, c)``: a scalar discrete-time signal ``v_k = c x_k`` fed back through ``b``.
    """

    A_d: np.ndarray
    T: float
    state_names: tuple[str, ...]
    controller: str
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


def sampled_cascade(cascade: LinearCascade, rate_hz: float = CONTROL_RATE_HZ, *, controller: str = "discrete",
                    torque_gain: float = 1.0) -> SampledLoop:
    """The exact sampled-data cascade at the sample instants.

    Parameters
    ----------
    cascade
        Linearised cascade (:func:`nniquad.analysis.cascade.linearise_cascade`).
    rate_hz
        Position sample rate = control rate [Hz].
    controller
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
                                    cascade.plant_states + cascade.controller_states, rate_hz, controller)


def sampled_loop_from_blocks(A_p: np.ndarray, B_p: np.ndarray, C_p: np.ndarray, A_k: np.ndarray, B_k: np.ndarray,
                             C_k: np.ndarray, D_k: np.ndarray, names: tuple[str, ...], rate_hz: float,
                             controller: str = "discrete") -> SampledLoop:
    """The sampled loop of a plant ``(A_p, B_p, C_p)`` (input ``a_h``) and controller ``(A_k, B_k, C_k, D_k)``.

    See :func:`sampled_cascade` for the two controller variants and the break points.
    """
    if controller not in CONTROLLER_VARIANTS:
        raise CascadeError(f"unknown controller variant {controller!r} (choose one of {', '.join(CONTROLLER_VARIANTS)})")
    T = _period(rate_hz)
    n_p, n_k = A_p.shape[0], A_k.shape[0]
    n_y = C_p.shape[0]
    breaks: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if controller == "discrete":
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
    return SampledLoop(A_d, T, tuple(names), controller, breaks)


def sampled_reduced_loop(vehicle, gains, rate_hz: float = CONTROL_RATE_HZ, *, controller: str = "discrete") -> SampledLoop:
    """The paper's reduced loop (``ξ'' = a_h``, both axes) sampled at ``rate_hz``, from the ``linear`` model.

    The plant and the controller are the Jacobian blocks of the simulator's
    ``linear`` model (:func:`nniquad.analysis.cascade.linearise`), split as in
    the cascade; the sampling is as in :func:`sampled_cascade`.
    """
    from nniquad.analysis.cascade import linearise
    from nniquad.sim import CONTROLLER_STATES, SimOptions, SimParams

    p = SimParams.from_options(vehicle, gains, SimOptions(model="linear", sample_hold=True))
    lin = linearise("linear", p)
    ctrl = CONTROLLER_STATES[p.controller]
    ik, ih = lin.index(*ctrl), lin.index("held_x", "held_y")
    plant = ("x", "x_dot", "y", "y_dot")
    ip = lin.index(*plant)
    A_k, B_k, C_k, D_k = lin.J[np.ix_(ik, ik)], lin.J[np.ix_(ik, ih)], lin.Y[:, ik], lin.Y[:, ih]
    # the plant sees the controller only through a_h (as in the cascade)
    B_p = lin.J[np.ix_(ip, ik + ih)] @ np.linalg.pinv(np.hstack([C_k, D_k]))
    C_p = np.zeros((2, len(plant)))
    C_p[0, plant.index("x")] = C_p[1, plant.index("y")] = 1.0
    return sampled_loop_from_blocks(lin.J[np.ix_(ip, ip)], B_p, C_p, A_k, B_k, C_k, D_k, plant + ctrl,
                                    rate_hz, controller)


def sampled_gain_interval(cascade: LinearCascade, rate_hz: float = CONTROL_RATE_HZ, *, controller: str = "discrete",
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
        return sampled_cascade(cascade, rate_hz, controller=controller, torque_gain=k).stable

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


# =============================================================================== Lyapunov certificate


@dataclass(frozen=True)
class DiscreteDecay:
    """A discrete-time Lyapunov certificate ``A_dᵀ P A_d ⪯ ρ² P``, ``P ≻ 0``.

    Attributes
    ----------
    P : ndarray
        The Lyapunov matrix (original coordinates).
    rho
        Certified contraction factor per period (numpy re-check ``rho_numpy <= rho``).
    rho_numpy
        ``‖P^{1/2} A_d P^{-1/2}‖₂``, the exact contraction of ``‖x‖_P`` in one period.
    spectral_radius
        ``max |eig(A_d)|``, the infimum of every certifiable ``ρ``.
    T
        Sample period [s].
    decay_rate_1_s
        ``-ln(rho)/T`` [1/s]: ``‖x(kT)‖_P <= e^{-rate kT} ‖x(0)‖_P``.
    min_eig_P
        Smallest eigenvalue of ``P`` (relative to its largest): must be positive.
    status
        Solver status of the last feasible solve.
    ok
        ``P ≻ 0`` and ``rho_numpy <= rho < 1`` (re-checked with numpy).
    """

    P: np.ndarray
    rho: float
    rho_numpy: float
    spectral_radius: float
    T: float
    decay_rate_1_s: float
    min_eig_P: float
    status: str
    ok: bool

    def to_json(self) -> dict[str, Any]:
        return {"rho": self.rho, "rho_numpy": self.rho_numpy, "spectral_radius": self.spectral_radius,
                "period_s": self.T, "rate_hz": 1.0 / self.T, "decay_rate_1_s": self.decay_rate_1_s,
                "min_eig_P_relative": self.min_eig_P, "status": self.status, "ok": self.ok,
                "P": self.P.tolist()}


def contraction(A_d: np.ndarray, P: np.ndarray) -> float:
    """``‖P^{1/2} A_d P^{-1/2}‖₂``: the factor by which one period shrinks ``‖x‖_P`` at most (numpy)."""
    Ls = np.linalg.cholesky(0.5 * (P + P.T))  # P = L Lᵀ, ‖x‖_P = ‖Lᵀ x‖
    M = Ls.T @ A_d @ np.linalg.inv(Ls.T)
    return float(np.linalg.norm(M, 2))


def _conditioning_transform(A: np.ndarray, max_cond: float = 1e8) -> np.ndarray:
    """A similarity ``S`` that makes ``S^{-1} A S`` well scaled for the SDP solver.

    The real modal form (scipy ``cdf2rdf`` of the eigenvectors) when its basis is
    well conditioned: there ``P = I`` nearly certifies the spectral radius, so
    the solver works near a well-scaled optimum.  Otherwise diagonal balancing
    (scipy ``matrix_balance``).  Any invertible ``S`` gives a valid certificate
    in the original coordinates; the numpy re-check is done there.
    """
    w, V = np.linalg.eig(A)
    try:
        _, Vr = sla.cdf2rdf(w, V)
        if np.linalg.cond(Vr) < max_cond:
            return np.real(Vr)
    except (ValueError, np.linalg.LinAlgError):
        pass
    _, (scale, _) = sla.matrix_balance(A, permute=False, separate=True)
    return np.diag(scale)


def solve_with_clarabel(prob: Any, var: Any) -> str | None:
    """Solve a cvxpy problem with Clarabel: its status when (inaccurately) optimal and ``var`` has a value, else ``None``.

    Every answer is re-checked with numpy by the caller, so an inaccurate optimum is offered, not trusted.
    """
    import cvxpy as cp

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            prob.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    if prob.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or var.value is None:
        return None
    return str(prob.status)


_Answer = TypeVar("_Answer")


def best_decay(solve: Callable[[float], tuple[float, _Answer] | None], rho_spec: float, T: float, *,
               rtol: float, max_iter: int) -> tuple[float, _Answer] | None:
    """The best certified contraction of a Lyapunov LMI family ``A_dᵀ P A_d ⪯ ρ² P`` (one search for every LMI here).

    ``solve(rho)`` solves the LMI for the target ``rho`` and returns
    ``(rho_numpy, answer)``: the contraction the answer achieves, re-checked
    with numpy, or ``None`` when the solver fails.  Any ``rho_numpy < 1`` is a
    certificate, whether it meets the target or not, and the smallest one seen
    is returned: near the spectral radius the solver often stops just short of
    the target yet beats every target a bisection would reach later.

    The decay ``(1 - rtol)`` of the spectral bound ``-ln(rho_spec)/T`` is tried
    first.  If its target is missed and no answer came back, the decay ``rtol``
    times the bound is tried (the slowest worth stating: a miss there ends the
    search).  The target decay is then bisected between the best decay
    achieved so far and the first target (at most ``max_iter`` solves), until
    that bracket is within ``rtol``.

    Parameters
    ----------
    solve
        ``solve(rho_target) -> (rho_numpy, answer) | None``.
    rho_spec
        The largest spectral radius of the loops (the infimum of any certified ``rho``), ``< 1``.
    T
        Sample period [s].
    rtol
        Relative accuracy of the decay rate ``-ln(rho)/T``.
    max_iter
        Bisection solves at most.

    Returns
    -------
    (rho, answer) or None
        ``None``: no solve gave a contraction below 1.
    """
    best: tuple[float, _Answer] | None = None

    def met(lam: float) -> bool:
        nonlocal best
        target = math.exp(-lam * T)
        got = solve(target)
        if got is None or not got[0] < 1.0:
            return False
        if best is None or got[0] < best[0]:
            best = got
        return got[0] <= target * (1 + 1e-9)

    def achieved() -> float:
        return -math.log(best[0]) / T if best is not None else 0.0

    lam_spec = -math.log(rho_spec) / T
    hi = lam_spec * (1 - rtol)
    if met(hi):
        return best
    if best is None:
        # the slowest decay worth stating: if even it is missed the LMI is (nearly) infeasible and a
        # bisection would only repeat failing solves
        if not met(lam_spec * rtol):
            return best
    lo = achieved()  # a certificate exists at the decay achieved so far: search above it only
    for _ in range(max_iter):
        if hi - lo <= rtol * hi:
            break
        mid = 0.5 * (lo + hi)
        lo, hi = (max(mid, achieved()), hi) if met(mid) else (lo, mid)
    return best


def discrete_lyapunov_decay(A_d: np.ndarray, T: float, *, rtol: float = 1e-3, max_iter: int = 40) -> DiscreteDecay:
    """Largest certified decay of ``x_{k+1} = A_d x_k``: the LMI ``A_dᵀ P A_d ⪯ ρ² P``, ``I ⪯ P``.

    For a fixed ``ρ`` the LMI is solved (cvxpy + Clarabel, minimising the
    condition bound ``t`` with ``P ⪯ t I``); the target ``ρ`` is searched by
    :func:`best_decay` between the spectral radius (the infimum) and 1, and the
    stated ``ρ`` is the numpy contraction of the best answer.  The LMI is posed in well-scaled
    coordinates (:func:`_conditioning_transform`) because the cascade mixes
    metres, radians and rotor speeds of ~10³ rad/s.

    Parameters
    ----------
    A_d
        Discrete closed-loop matrix.
    T
        Sample period [s].
    rtol
        Relative accuracy of the decay rate.
    max_iter
        Bisection steps at most.

    Returns
    -------
    DiscreteDecay

    Raises
    ------
    SolverError
        Unstable ``A_d`` (no certificate exists) or no feasible solve.
    """
    import cvxpy as cp

    A_d = np.asarray(A_d, float)
    n = A_d.shape[0]
    rho_spec = float(np.max(np.abs(np.linalg.eigvals(A_d))))
    if not rho_spec < 1.0:
        raise SolverError(f"discrete Lyapunov LMI: the sampled loop is unstable (spectral radius {rho_spec:.6g})")
    S = _conditioning_transform(A_d)  # A_d = S Ab S^{-1}
    Ab = np.linalg.solve(S, A_d @ S)
    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    rho2 = cp.Parameter(nonneg=True)
    Pm = 0.5 * (P + P.T)
    cons = [Pm >> np.eye(n), Pm << t * np.eye(n),
            rho2 * Pm - Ab.T @ Pm @ Ab >> 0]
    prob = cp.Problem(cp.Minimize(t), cons)
    Sinv = np.linalg.inv(S)

    def solve(rho: float) -> tuple[float, np.ndarray] | None:
        rho2.value = rho * rho
        if solve_with_clarabel(prob, P) is None:
            return None
        Pb = 0.5 * (P.value + P.value.T)
        Po = Sinv.T @ Pb @ Sinv  # xᵀ P x = (S^{-1} x)ᵀ Pb (S^{-1} x)
        Po = 0.5 * (Po + Po.T)
        try:
            return contraction(A_d, Po), Po
        except np.linalg.LinAlgError:  # not positive definite
            return None

    lam_spec = -math.log(rho_spec) / T
    best = best_decay(solve, rho_spec, T, rtol=rtol, max_iter=max_iter)
    if best is None:
        raise SolverError(f"discrete Lyapunov LMI: no feasible P for any decay in (0, {lam_spec:.4g}) 1/s")
    rho, Pbest = best
    rho_num = contraction(A_d, Pbest)
    ev = np.linalg.eigvalsh(Pbest)
    min_rel = float(ev[0] / ev[-1])
    ok = bool(min_rel > 0 and rho_num <= rho * (1 + 1e-9) and rho < 1)
    return DiscreteDecay(P=Pbest, rho=rho, rho_numpy=rho_num, spectral_radius=rho_spec, T=T,
                         decay_rate_1_s=-math.log(rho) / T, min_eig_P=min_rel, status=str(prob.status), ok=ok)
