"""The sampled cascade at many parameter points, its decoupled subsystems, and the coordinates that reach each.

:func:`sampled_family` linearises the simulator's full model at hover and samples it at every point of a box
at once (one mapped CasADi evaluation, one stacked ``expm``).  After a fixed orthogonal change of the rotor
coordinates (:func:`mode_transform`) the loop splits into four blocks that do not feed each other
(:data:`SUBSYSTEMS`); :func:`coupling` measures what is left and :func:`relevant_coordinates` which of the six
point coordinates change each block.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any, Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from nniquad.analysis.batch_eval import evaluate_map
from nniquad.analysis.cascade.box import POINT_NAMES, ParameterBox
from nniquad.analysis.hover_jacobian import EQUILIBRIUM_TOL, LINEARISATION_OFFSET_M, Linearisation, jacobian_function
from nniquad.analysis.linearised_cascade import LinearCascade, allocation_jacobian, hover_params, split_cascade
from nniquad.analysis.sampled import control_period
from nniquad.config import CONTROL_RATE_HZ, TILT_LIMIT_DEG
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CascadeError
from nniquad.laws.base import GainBlock
from nniquad.model.layout import DEFAULT_FRAME
from nniquad.model.numeric import rotor_modes
from nniquad.model.vehicle import Vehicle
from nniquad.sim import delay_state_names, initial_state, param_layout, state_names

__all__ = ["CascadeFamily", "sampled_family", "with_delay_line", "anti_windup_rows", "SUBSYSTEMS", "subsystems",
           "COUPLING_TOL", "RELEVANCE_TOL",
           "RELEVANCE_BAND", "mode_transform", "coupling", "relevant_coordinates", "relevance_consistent"]

# =============================================================================== the family of sampled loops


@dataclass(frozen=True)
class CascadeFamily:
    """The sampled cascade at many parameter points (batched; index 0 of every array is a point).

    Attributes
    ----------
    points : ndarray (N, 6)
        The parameter points (:data:`POINT_NAMES`).
    state_names
        Plant states then the law's controller states (:attr:`nniquad.laws.base.ControlLaw.sim_state_names`).
    T
        Sample period [s].
    A_p, B_p : ndarray (N, n_p, n_p), (N, n_p, 2)
        Continuous plant, input the held acceleration command ``a_h`` [m/s²].
    C_p : ndarray (2, n_p)
        Position output.
    A_k, B_k, C_k, D_k
        The controller (continuous; the same at every point: it is the flight code's).
    A_kd, B_kd
        Its exact ZOH equivalent.
    Phi, Gam : ndarray (N, n_p, n_p), (N, n_p, 2)
        The plant's exact ZOH discretisation.
    A_d : ndarray (N, n, n)
        Closed loop ``x_{k+1} = A_d x_k`` (``n = n_p + 2``).
    A0, B : ndarray (N, n, n), (N, n, 2)
        Saturation split ``x_{k+1} = A0 x_k + B a_k`` with ``a_k = sat_L(K x_k)``, ``A0 + B K = A_d``; with an
        anti-windup (:func:`anti_windup_rows` ``E``) ``A0`` holds ``E K`` and ``B`` is ``Γ - E``: ``B`` then has
        controller rows.
    K : ndarray (2, n)
        The acceleration command ``a_k = K x_k`` before the tilt limit.
    accel_limit : ndarray (N,)
        Norm limit ``L = g_z tan(tilt)`` of ``a_h`` at hover, ``g_z = (m/m̂) g`` [m/s²].
    residual : ndarray (N,)
        ``max |f(x_eq)|`` of each equilibrium.
    W_r, W_a, A_rw
        Motor-command blocks (for :meth:`cascade_at`).
    frame
        The vehicle's rotor layout (its rotor modes: :func:`mode_transform`).
    delay_samples
        Measurement delay ``N`` [samples]: the state ends with the delay line ``d_j = ξ_{k-j}``
        (:func:`nniquad.sim.params.delay_state_names`), the law reads ``d_N`` in place of ``C_p x``.
    """

    points: np.ndarray
    state_names: tuple[str, ...]
    T: float
    A_p: np.ndarray
    B_p: np.ndarray
    C_p: np.ndarray
    A_k: np.ndarray
    B_k: np.ndarray
    C_k: np.ndarray
    D_k: np.ndarray
    A_kd: np.ndarray
    B_kd: np.ndarray
    Phi: np.ndarray
    Gam: np.ndarray
    A_d: np.ndarray
    A0: np.ndarray
    B: np.ndarray
    K: np.ndarray
    accel_limit: np.ndarray
    residual: np.ndarray
    W_r: np.ndarray
    W_a: np.ndarray
    A_rw: np.ndarray
    tau_motor: np.ndarray
    context: Any = None
    frame: str = DEFAULT_FRAME
    delay_samples: int = 0

    def __len__(self) -> int:
        return self.points.shape[0]

    @cached_property
    def spectral_radius(self) -> np.ndarray:
        """Spectral radius of ``A_d`` at every point (computed once per family: :func:`take_points` keeps it)."""
        return np.max(np.abs(np.linalg.eigvals(self.A_d)), axis=-1)

    def cascade_at(self, i: int) -> LinearCascade:
        """The :class:`LinearCascade` of point ``i`` (for the continuous-time margins)."""
        ctx = self.context
        n_p, n_k = self.A_p.shape[1], self.A_k.shape[0]  # the delay line, if any, is not the cascade's
        return LinearCascade(
            vehicle=ctx["vehicle"], gains=ctx["gains"], inner=ctx["inner"], motor_lag=True, lin=ctx["lin"],
            plant_states=self.state_names[:n_p], rigid_states=ctx["rigid"],
            controller_states=self.state_names[n_p:n_p + n_k],
            A_p=self.A_p[i], B_p=self.B_p[i], C_p=self.C_p, A_k=self.A_k, B_k=self.B_k, C_k=self.C_k, D_k=self.D_k,
            W_r=self.W_r[i], W_a=self.W_a[i], A_rw=self.A_rw[i], tau_motor=float(self.tau_motor[i]),
            M_alloc=ctx["M_alloc"])


def _batched_expm(M: np.ndarray) -> np.ndarray:
    return sla.expm(M)  # scipy >= 1.9 exponentiates a stack (..., n, n)


def sampled_family(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, points: np.ndarray, *,
                   tilt_limit_deg: float = TILT_LIMIT_DEG, rate_hz: float = CONTROL_RATE_HZ,
                   delay_samples: int = 0) -> CascadeFamily:
    """Linearise and sample the cascade at many parameter points at once.

    One mapped CasADi evaluation of the simulator's Jacobians (at ``±ε`` on the
    held measurement, as :func:`nniquad.analysis.linearised_cascade.linearise` does) and
    one stacked ``expm`` give every point's plant; the split into plant and
    controller is that of :func:`nniquad.analysis.linearised_cascade.linearise_cascade`
    (its exactness is checked at every point).

    Parameters
    ----------
    vehicle, gains, inner
        The nominal design.
    points : array (N, 6)
        Parameter points (:data:`POINT_NAMES`).
    tilt_limit_deg
        Tilt limit [deg] (sets :attr:`CascadeFamily.accel_limit`; inactive at hover).
    rate_hz
        Sample rate [Hz].
    delay_samples
        Measurement delay ``N`` [samples] (:func:`with_delay_line`).

    Raises
    ------
    CascadeError
        A point that is not an equilibrium, an inexact split, a bad point.
    """
    T = control_period(rate_hz)
    pts = np.atleast_2d(np.asarray(points, float))
    if pts.shape[1] != len(POINT_NAMES) or not np.all(np.isfinite(pts)) or np.any(pts <= 0):
        raise CascadeError(f"parameter points must be positive factors of shape (N, {len(POINT_NAMES)})")
    N = pts.shape[0]
    base = hover_params(vehicle, gains, inner, tilt_limit_deg, None).with_(run={"sample_hold": 1.0})
    law = base.controller
    names = [f.name for f in param_layout(law)]
    col = {n: i for i, n in enumerate(names)}
    pv = np.tile(base.vector(), (N, 1))
    nom = base.plant
    pv[:, col["plant.m"]] = nom.m * pts[:, 0]
    pv[:, col["plant.Jx"]] = nom.Jx * pts[:, 1]
    pv[:, col["plant.Jy"]] = nom.Jy * pts[:, 2]
    pv[:, col["plant.Jz"]] = nom.Jz * pts[:, 3]
    pv[:, col["inner.attitude_gain_scale"]] = base.inner.attitude_gain_scale * pts[:, 4]
    tau = nom.tau_motor * pts[:, 5]
    pv[:, col["plant.tau_motor"]] = tau
    # the hover equilibrium of a heavier/lighter vehicle: the altitude integrator holds a_z = g (1 - m/m̂)
    snames = state_names("full", law)
    si = {n: i for i, n in enumerate(snames)}
    x_eq = np.tile(initial_state("full", base, (0.0, 0.0)), (N, 1))
    m_true = pv[:, col["plant.m"]]
    g = base.nominal.g
    a_z = g * (1.0 - m_true / base.nominal.m)
    x_eq[:, si["z_int"]] = -a_z / base.inner.altitude_wn_rad_s ** 3
    w_hover = np.sqrt(m_true * nom.g / (4.0 * nom.b))
    for k in range(1, 5):
        x_eq[:, si[f"w{k}"]] = w_hover
    jac = jacobian_function("full", law)
    d = np.zeros(len(snames))
    d[si["held_x"]] = LINEARISATION_OFFSET_M
    X = np.vstack([x_eq + d, x_eq - d]).T
    Pm = np.vstack([pv, pv]).T
    _, Jm, Ym = evaluate_map(jac, 2 * N, X, Pm)  # (2N, nx, nx), (2N, 2, nx)
    # residual at the equilibrium itself (the ±ε points differ from it only in the held measurement)
    f_eq = evaluate_map(jac, N, x_eq.T, pv.T)[0][:, :, 0]
    residual = np.max(np.abs(f_eq), axis=1)
    if not np.all(residual <= EQUILIBRIUM_TOL * max(1.0, float(np.max(w_hover)) / 100.0)):
        i = int(np.argmax(residual))
        raise CascadeError(f"hover is not an equilibrium at point {pts[i].tolist()} (|f| = {residual[i]:.3g})")
    J = 0.5 * (Jm[:N] + Jm[N:])
    Y = 0.5 * (Ym[:N] + Ym[N:])
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(Y))):
        raise CascadeError("a Jacobian of the cascade is not finite")
    split = split_cascade(J, Y, snames, gains.law.sim_state_names)
    rigid, motors, ctrl = split.rigid, split.motors, split.controller
    ir, iw = split.ir, split.iw
    A_k, B_k, C_k, D_k, A_p, B_p = split.A_k, split.B_k, split.C_k, split.D_k, split.A_p, split.B_p
    nr = len(ir)
    n_p, n_k = len(ir) + len(iw), len(ctrl)
    C_p = np.zeros((2, n_p))
    C_p[0, rigid.index("x")] = C_p[1, rigid.index("y")] = 1.0
    # exact ZOH of the plant (stacked) and of the controller
    Mz = np.zeros((N, n_p + 2, n_p + 2))
    Mz[:, :n_p, :n_p], Mz[:, :n_p, n_p:] = A_p * T, B_p * T
    E = _batched_expm(Mz)
    Phi, Gam = E[:, :n_p, :n_p], E[:, :n_p, n_p:]
    Ek = sla.expm(np.block([[A_k, B_k], [np.zeros((2, n_k + 2))]]) * T)
    A_kd, B_kd = Ek[:n_k, :n_k], Ek[:n_k, n_k:]
    n = n_p + n_k
    K = np.hstack([D_k @ C_p, C_k])
    A0 = np.zeros((N, n, n))
    A0[:, :n_p, :n_p] = Phi
    A0[:, n_p:, :n_p] = B_kd @ C_p
    A0[:, n_p:, n_p:] = A_kd
    Bs = np.zeros((N, n, 2))
    Bs[:, :n_p] = Gam
    A0, Bs, K = with_delay_line(A0, Bs, K, C_p, B_kd, D_k, delay_samples)
    A_d = A0 + Bs @ K
    # the law's anti-windup, linear in the dead zone: x⁺ = A0 x + Bs sat(Kx) + E (Kx - sat(Kx)), so A0 + E K and
    # Bs - E split the same A_d (zero for a law without one)
    E = np.zeros((A0.shape[-1], 2))  # the delay line's states, after the controller's, have none
    E[n_p:n] = anti_windup_rows(gains, vehicle.m, ctrl, T)
    A0 = A0 + E @ K
    Bs = Bs - E
    A_wr = J[:, iw][:, :, ir]
    W_r = tau[:, None, None] * A_wr
    W_a = tau[:, None, None] * B_p[:, nr:]
    A_rw = J[:, ir][:, :, iw]
    L = (m_true / base.nominal.m) * g * math.tan(math.radians(tilt_limit_deg))
    lin0 = Linearisation("full", snames, x_eq[0], float(residual[0]), J[0], Y[0], base)
    ctx = {"vehicle": vehicle, "gains": gains, "inner": inner, "lin": lin0, "rigid": rigid,
           "M_alloc": allocation_jacobian(base)}
    return CascadeFamily(points=pts, state_names=tuple(rigid + motors + ctrl) + delay_state_names(delay_samples), T=T,
                         A_p=A_p, B_p=B_p, C_p=C_p,
                         A_k=A_k, B_k=B_k, C_k=C_k, D_k=D_k, A_kd=A_kd, B_kd=B_kd, Phi=Phi, Gam=Gam, A_d=A_d, A0=A0,
                         B=Bs, K=K, accel_limit=L, residual=residual, W_r=W_r, W_a=W_a, A_rw=A_rw, tau_motor=tau,
                         context=ctx, frame=vehicle.frame, delay_samples=int(delay_samples))


def with_delay_line(A0: np.ndarray, B: np.ndarray, K: np.ndarray, C_p: np.ndarray, B_kd: np.ndarray,
                    D_k: np.ndarray, delay_samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The saturation split ``(A0, B, K)`` with a measurement delay line of ``N`` samples appended to the state.

    The state becomes ``(x_p, x_k, d_1, ..., d_N)``, ``d_j = C_p x_{p,k-j}`` (both axes per sample, the order
    of :func:`nniquad.sim.params.delay_state_names`).  The law reads ``d_N`` where it read ``C_p x_p``: the
    controller update ``x_k⁺ = A_kd x_k + B_kd d_N`` and the command ``a = C_k x_k + D_k d_N``; the line
    shifts, ``d_1⁺ = C_p x_p``, ``d_j⁺ = d_{j-1}``.  ``N = 0`` returns the arguments.

    Parameters
    ----------
    A0 : array (N_pts, n, n)
        The split without delay (``n = n_p + n_k``).
    B : array (N_pts, n, 2)
        Its input.
    K : array (2, n)
        Its command.
    C_p : array (2, n_p)
        Position output of the plant.
    B_kd, D_k
        The controller's sampled input and feedthrough (:class:`CascadeFamily`).
    delay_samples
        ``N``.
    """
    N = int(delay_samples)
    if N <= 0:
        return A0, B, K
    n_p, n = C_p.shape[1], A0.shape[-1]
    nd = 2 * N
    last = np.zeros((2, nd))
    last[:, nd - 2:] = np.eye(2)  # d_N
    A = np.zeros(A0.shape[:-2] + (n + nd, n + nd))
    A[..., :n, :n] = A0
    A[..., n_p:n, :n_p] = 0.0  # the controller no longer reads the position now ...
    A[..., n_p:n, n:] = B_kd @ last  # ... but the one N samples old
    A[..., n:n + 2, :n_p] = C_p
    A[..., n + 2:, n:n + nd - 2] = np.eye(nd - 2)
    Bd = np.zeros(B.shape[:-2] + (n + nd, B.shape[-1]))
    Bd[..., :n, :] = B
    Kd = np.hstack([np.zeros((2, n_p)), K[:, n_p:], D_k @ last])
    return A, Bd, Kd


def anti_windup_rows(gains: GainBlock, m_hat: float, names: Sequence[str], T: float) -> np.ndarray:
    """``E`` on the controller states ``names`` (``(len(names), 2)``): ``T`` times the law's anti-windup gain of
    each state (:meth:`nniquad.laws.base.ControlLaw.anti_windup_gains`) in its axis's column, so that one sample
    adds ``E (a - sat(a))`` to them (``q⁺ = q + T (ξ + (a - sat(a))/k_s)`` of an integral law); zero without one.

    Parameters
    ----------
    gains
        The design.
    m_hat
        The controller's nominal mass [kg].
    names
        The controller states of the family, as the simulator names them (``zci_x``, ...).
    T
        Sample period [s].
    """
    law = gains.law
    per_axis = law.anti_windup_gains(law.parameters(gains, m_hat))
    E = np.zeros((len(names), 2))
    if per_axis is None:
        return E
    for i, name in enumerate(names):
        base, axis = name.rsplit("_", 1)
        E[i, "xy".index(axis)] = T * float(per_axis[law.state_names.index(base)])
    return E


def take_points(fam: CascadeFamily, idx: np.ndarray) -> CascadeFamily:
    """The points ``idx`` of a family."""
    kw = {}
    for f in fields(fam):
        v = getattr(fam, f.name)
        kw[f.name] = v[idx] if isinstance(v, np.ndarray) and v.ndim >= 1 and v.shape[0] == len(fam) \
            and f.name not in ("C_p", "K", "A_k", "B_k", "C_k", "D_k", "A_kd", "B_kd") else v
    out = CascadeFamily(**kw)
    if "spectral_radius" in fam.__dict__:  # already computed: a cached_property, so set it the same way
        out.__dict__["spectral_radius"] = fam.__dict__["spectral_radius"][idx]
    return out


# =============================================================================== decoupled subsystems

_ROTOR_MODE_NAMES = ("m_collective", "m_roll", "m_pitch", "m_yaw")
#: The subsystems of the cascade at hover after :func:`mode_transform` (position first, controller state
#: last in each horizontal axis, the same order on both axes), with a one-state controller law (NNI).
SUBSYSTEMS: dict[str, tuple[str, ...]] = {
    "x": ("x", "x_dot", "theta", "theta_dot", "m_pitch", "zc_x"),
    "y": ("y", "y_dot", "phi", "phi_dot", "m_roll", "zc_y"),
    "altitude": ("z", "z_dot", "z_int", "m_collective"),
    "yaw": ("psi", "psi_dot", "m_yaw"),
}


def subsystems(state_names: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """:data:`SUBSYSTEMS` of a cascade with these states: each horizontal axis ends with every controller state of
    that axis, in state order (NNI: ``zc_x``; ``sni2``: ``zc_x, zcd_x``)."""
    ctrl = [n for n in state_names if n.startswith("zc")]
    out = dict(SUBSYSTEMS)
    for axis in ("x", "y"):
        out[axis] = SUBSYSTEMS[axis][:-1] + tuple(n for n in ctrl if n.endswith(f"_{axis}"))
    return out


def mode_transform(state_names: Sequence[str], frame: str) -> tuple[np.ndarray, tuple[str, ...]]:
    """The fixed orthogonal map ``ζ = T_m x`` to the coordinates of :func:`subsystems` (rotor modes, permuted).

    The rotor speeds become the collective, roll pair, pitch pair and yaw modes of the
    vehicle's ``frame``: the normalised rows of its mixer (:func:`nniquad.model.numeric.rotor_modes`;
    '+': roll from w4 - w2, pitch from w1 - w3).

    Returns ``T_m`` (rows in the order x, y, altitude, yaw subsystems) and the new state names.
    """
    names = list(state_names)
    subs = subsystems(names)
    n = len(names)
    R = np.eye(n)
    iw = [names.index(f"w{k}") for k in range(1, 5)]
    R[np.ix_(iw, iw)] = rotor_modes(frame)
    mode_names = list(names)
    for i, m in zip(iw, _ROTOR_MODE_NAMES):
        mode_names[i] = m
    order = [mode_names.index(s) for sub in subs.values() for s in sub]
    if sorted(order) != list(range(n)):
        raise CascadeError("the subsystems do not partition the cascade's states")
    return R[order], tuple(mode_names[i] for i in order)


def subsystem_blocks(state_names: Sequence[str] | None = None) -> dict[str, slice]:
    """Each subsystem's slice of the mode coordinates (:func:`subsystems` of ``state_names``; NNI's without)."""
    out, k = {}, 0
    for name, sub in (SUBSYSTEMS if state_names is None else subsystems(state_names)).items():
        out[name] = slice(k, k + len(sub))
        k += len(sub)
    return out


def coupling(family: CascadeFamily) -> float:
    """Largest coupling between the subsystems of ``T_m A_d T_mᵀ``, relative (diagonal balancing of the nominal loop).

    Zero in exact arithmetic at hover (the altitude, yaw and the two horizontal
    axes decouple at first order); what remains is the ``O(ε²)`` error of the
    symmetric-mean Jacobian (:mod:`nniquad.analysis.linearised_cascade`), about ``1e-12``.
    """
    Tm, _ = mode_transform(family.state_names, family.frame)
    Z = Tm @ family.A_d @ Tm.T
    _, (s, _) = sla.matrix_balance(Z[0], permute=False, separate=True)
    Zb = Z / s[None, :, None] * s[None, None, :]
    mask = np.ones(Z.shape[1:], bool)
    for sl in subsystem_blocks(family.state_names).values():
        mask[sl, sl] = False
    return float(np.max(np.abs(Zb[:, mask])) / max(np.max(np.abs(Zb)), 1.0))


def subsystem_of(family: CascadeFamily, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A_d, A0, B, K)`` of one subsystem at every point (B and K: the axis's own input/command; else None)."""
    Tm, _ = mode_transform(family.state_names, family.frame)
    sl = subsystem_blocks(family.state_names)[name]
    R = Tm[sl]
    A_d = R @ family.A_d @ R.T
    A0 = R @ family.A0 @ R.T
    ax = {"x": 0, "y": 1}.get(name)
    if ax is None:
        return A_d, A0, None, None
    return A_d, A0, (R @ family.B)[:, :, ax:ax + 1], (family.K @ R.T)[ax:ax + 1]


#: Coupling above which the subsystems are not treated as decoupled.  What remains at hover is the O(ε²)
#: error of the symmetric-mean Jacobian amplified by the rotor and inertia scales (1e-11 to 4e-9 on the
#: designs tested); whatever it is, the grid check runs on the full, coupled 19-state loop.
COUPLING_TOL = 1e-7


def relevance_points(box: ParameterBox) -> np.ndarray:
    """Nominal, then each coordinate moved alone to its low and high end: ``(13, 6)``."""
    lo, hi = box.bounds()
    pts = [np.ones(6)]
    for j in range(6):
        for v in (lo[j], hi[j]):
            p = np.ones(6)
            p[j] = v
            pts.append(p)
    return np.array(pts)


#: A coordinate that changes a subsystem's loop by more than this (relative) is in its LMI (:func:`relevant_coordinates`).
RELEVANCE_TOL = 1e-9
#: ``verify`` accepts either choice for a change within this factor of :data:`RELEVANCE_TOL` (a threshold
#: decision must not depend on rounding; the changes seen are >= 1e-2 or <= 1e-10, rounding moves them by 1e-16).
RELEVANCE_BAND = 10.0


def _relevance_changes(fam: CascadeFamily, box: ParameterBox) -> dict[str, np.ndarray]:
    """How much each coordinate, moved alone to either end of the box, changes each subsystem (relative; 0 where
    the box is degenerate)."""
    lo, hi = box.bounds()
    out = {}
    for name in SUBSYSTEMS:
        A = subsystem_of(fam, name)[0]
        scale = max(float(np.max(np.abs(A[0]))), 1.0)
        out[name] = np.array([max(np.max(np.abs(A[1 + 2 * j] - A[0])), np.max(np.abs(A[2 + 2 * j] - A[0]))) / scale
                              if hi[j] > lo[j] else 0.0 for j in range(6)])
    return out


def _relevance_from(fam: CascadeFamily, box: ParameterBox, tol: float = RELEVANCE_TOL) -> dict[str, tuple[int, ...]]:
    return {name: tuple(int(j) for j in np.flatnonzero(ch > tol)) for name, ch in _relevance_changes(fam, box).items()}


def relevance_consistent(fam: CascadeFamily, box: ParameterBox, dims: Mapping[str, Sequence[int]]) -> bool:
    """Whether stated ``dims`` hold every clearly relevant coordinate and no clearly irrelevant one.

    A change above ``RELEVANCE_TOL * RELEVANCE_BAND`` must be in, one below ``RELEVANCE_TOL / RELEVANCE_BAND``
    must be out, and one in between may be either (its side of the threshold could depend on rounding).
    """
    for name, ch in _relevance_changes(fam, box).items():
        stated = set(dims.get(name, ()))
        if any((ch[j] > RELEVANCE_TOL * RELEVANCE_BAND and j not in stated)
               or (ch[j] < RELEVANCE_TOL / RELEVANCE_BAND and j in stated) for j in range(6)):
            return False
    return True


def relevant_coordinates(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, box: ParameterBox, *,
                         tilt_limit_deg: float, rate_hz: float, tol: float = RELEVANCE_TOL,
                         delay_samples: int = 0) -> dict[str, tuple[int, ...]]:
    """Which point coordinates change each subsystem's ``A_d`` (moving one coordinate to each end of the box).

    A coordinate that changes a subsystem by less than ``tol`` (relative) is
    left out of that subsystem's LMI; the grid check on the full 19-state loop
    (:func:`grid_check`) is done with all six.
    """
    fam = sampled_family(vehicle, gains, inner, relevance_points(box), tilt_limit_deg=tilt_limit_deg,
                         rate_hz=rate_hz, delay_samples=delay_samples)
    return _relevance_from(fam, box, tol)


#: Families rebuilt by :func:`check_cascade_section` in this process, by their exact inputs: the rebuild is
#: a pure function of the design, the rate and the points, and a tampering loop re-checks one design hundreds
#: of times (every stated number is still compared afresh against it).
_FAMILIES: dict[tuple, "CascadeFamily"] = {}


def family_cached(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, points: np.ndarray, tilt_limit_deg: float,
                   rate_hz: float, delay_samples: int = 0) -> "CascadeFamily":
    pts = np.ascontiguousarray(points, dtype=float)
    key = (vehicle, gains, inner, float(tilt_limit_deg), float(rate_hz), pts.shape, pts.tobytes(), int(delay_samples))
    if key not in _FAMILIES:
        if len(_FAMILIES) >= 16:
            _FAMILIES.clear()
        _FAMILIES[key] = sampled_family(vehicle, gains, inner, pts, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                                        delay_samples=delay_samples)
    return _FAMILIES[key]
