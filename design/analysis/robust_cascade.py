"""The sampled-data cascade certified over a box of parameters: robust Lyapunov LMI, grid check, region of attraction.

What is certified
-----------------
The linearised cascade of :mod:`nniquad.analysis.cascade` (the simulator's
CasADi Jacobians at hover: rigid body, altitude PID and yaw hold, attitude PD in
its linear region, allocation, first-order motor lag, NNI controller), sampled
as in :mod:`nniquad.analysis.sampled`: the position is sampled at ``rate_hz``
and held (exact ZOH), the NNI controller runs in discrete time (its exact ZOH
equivalent, variant ``"discrete"``, its output held over the period), the
attitude loop, the motors and the altitude loop are **continuous**.  All 19
states are kept (no reduction to the horizontal subsystem).

The parameter box
-----------------
:class:`ParameterBox` holds four intervals of factors on the vehicle's nominal
values.  At a parameter point the *true* vehicle has mass ``f_m m``, inertias
``f_Jx Jx, f_Jy Jy, f_Jz Jz`` (the **three inertia factors vary independently**
inside ``inertia_factor``, as the Monte Carlo draws them), motor time constant
``f_τ τ_m``, and the attitude torques are multiplied by ``f_a``
(:attr:`nniquad.control.gains.InnerLoopGains.attitude_gain_scale` times
``f_a``).  The controller's nominal mass ``m̂`` and the inner loops' nominal
inertias stay nominal: they are what the flight code knows.  A point is thus
six numbers ``θ = (f_m, f_Jx, f_Jy, f_Jz, f_a, f_τ)`` (:data:`POINT_NAMES`);
the box has ``2^6 = 64`` vertices.

With ``m ≠ m̂`` hover is an equilibrium with the altitude integrator holding
``a_z = g (1 - m/m̂)`` (so that ``u1 = m̂ (g - a_z) = m g``) and the rotors at
``sqrt(m g / 4b)``; the residual ``|f(x_eq)|`` is checked at every point.

Decoupled subsystems
--------------------
After a fixed orthogonal change of the rotor coordinates (collective, roll
pair, pitch pair, yaw: :func:`mode_transform`) the loop at hover splits into
four blocks that do not feed each other (:data:`SUBSYSTEMS`: the x axis, the y
axis, the altitude loop, the yaw hold); :func:`coupling` measures what is left
(the ``O(ε²)`` error of the Jacobian, below :data:`COUPLING_TOL`).  Each block
depends on some of the six coordinates only (:func:`relevant_coordinates`:
the x axis on mass, Jy, attitude gain and motor; the y axis on Jx instead).

Certificates and what they cover
--------------------------------
* :func:`robust_lyapunov`, per block: ``P(θ) = P_0 + Σ θ_j P_j`` (``θ ∈ [-1, 1]``
  the block's log factors normalised on the box) with
  ``A_d(θ)ᵀ P(θ) A_d(θ) ⪯ ρ² P(θ)`` at the **LMI points** (a grid of
  :data:`LMI_POINTS_PER_AXIS` = 3 per coordinate: the vertices, the centre and
  the mid-faces) and ``I ⪯ P(θ)`` on the whole cube (affine: checked at its
  corners); decay ``-ln ρ / T``.  A common ``P`` was tried first: for the
  certified design no common ``P`` exists even for the two motor time
  constants 0.5 and 2 times nominal alone, so the Lyapunov matrix depends on
  the (constant, unknown) parameters, which is all a time-invariant
  uncertainty needs.  ``A_d(θ)`` is not affine in ``θ`` (matrix exponentials of
  Jacobians), so nothing is proved between the LMI points.
* :func:`grid_check`: the exact contraction factor ``‖P^{1/2} A_d(θ) P^{-1/2}‖₂``
  of the assembled 19-state ``P(θ)`` (:func:`_assemble_P`, on the full coupled
  loop) and the spectral radius, with numpy, on a grid of
  :data:`nniquad.config.CASCADE_GRID_POINTS_PER_AXIS` points per coordinate
  in all six coordinates (4096 points; other points than the LMI points except
  the vertices): the interior is covered **at the grid points only**.
* Region of attraction under the norm tilt limit ``‖a‖ <= u0``,
  ``u0 = (lowest mass factor) g tan(tilt)`` (the limit is ``g_z tan(tilt)`` with
  ``g_z = (m/m̂) g`` at hover): by default the linear-zone ellipsoid of the
  grid-checked ``P(θ)`` (:func:`linear_zone_reach`; the generalised sector
  condition with ``G = 0``), the smallest reach over the LMI and grid points.
  The horizontal blocks' ``P(θ)`` is re-solved for the widest such reach
  (:func:`reach_lyapunov`, at :data:`nniquad.config.CASCADE_REACH_DECAY_FRACTION`
  of the block's best decay) and kept when it reaches further and passes the
  grid check; the ellipsoid cannot reach beyond about ``u0 / kp`` (the command
  of a pure position offset).  A vehicle whose y block mirrors its x block
  reuses x's answers, re-checked with numpy on y's loops (:func:`_mirror`).
  :func:`robust_region_of_attraction` solves the discrete-time generalised
  sector condition (Gomes da Silva & Tarbouriech, IEEE TAC 50(1), 2005; vector
  form and scalar multiplier as in :mod:`nniquad.analysis.lmi.roa`) for
  ``x_{k+1} = A_0 x_k + B sat_u0(K x_k)`` with affine ``W(θ), Z(θ)``; it is used
  (``roa_method="gsc"``) only when its numpy re-check passes on the whole grid.
"""

from __future__ import annotations

import itertools
import math
import time
import warnings
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from typing import Any, Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from nniquad.analysis.cascade import (SPLIT_TOL, EQUILIBRIUM_TOL, LINEARISATION_OFFSET_M, LinearCascade, Linearisation,
                                      _hover_params, _jacobian_function, allocation_jacobian)
from nniquad.analysis.lmi import checks as lmi_checks
from nniquad.analysis.mapped import evaluate_map
from nniquad.analysis.sampled import _conditioning_transform, _period, best_decay, solve_with_clarabel
from nniquad.config import (CASCADE_GRID_POINTS_PER_AXIS, CASCADE_LYAPUNOV_RTOL, CASCADE_REACH_DECAY_FRACTION,
                            CASCADE_ROA_DECAY_FRACTION,
                            CASCADE_SMALLEST_SCALE, CASCADE_WIDEST_SCALE_MAX, CASCADE_WIDEST_STEPS, CONTROL_RATE_HZ,
                            TILT_LIMIT_DEG)
from nniquad.control.gains import Gains, InnerLoopGains
from nniquad.errors import CascadeError, SolverError
from nniquad.model.vehicle import Vehicle
from nniquad.sim import STATE_NAMES, initial_state, param_layout

__all__ = [
    "BOX_KEYS",
    "POINT_NAMES",
    "ParameterBox",
    "CascadeFamily",
    "sampled_family",
    "RobustLyapunov",
    "robust_lyapunov",
    "GridCheck",
    "grid_check",
    "RobustROA",
    "robust_region_of_attraction",
    "roa_recheck",
    "widest_box",
    "reach_lyapunov",
    "cascade_section",
    "check_cascade_section",
    "SUBSYSTEMS",
    "COUPLING_TOL",
    "LMI_POINTS_PER_AXIS",
    "mode_transform",
    "coupling",
    "relevant_coordinates",
    "contraction_batch",
    "linear_zone_reach",
]

#: Keys of a box in JSON, in order.
BOX_KEYS: tuple[str, ...] = ("mass_factor", "inertia_factor", "attitude_gain_factor", "tau_motor_factor")
#: Coordinates of a parameter point (the inertia factor is three independent coordinates).
POINT_NAMES: tuple[str, ...] = ("mass", "Jx", "Jy", "Jz", "attitude_gain", "tau_motor")
_POINT_BOX = (0, 1, 1, 1, 2, 3)  # which box interval each point coordinate takes


# =============================================================================== the box


def _interval(name: str, value: Any) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise CascadeError(f"box {name} must be a pair [low, high] of factors, got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo <= hi):
        raise CascadeError(f"box {name} must be finite factors with 0 < low <= high, got [{lo:g}, {hi:g}]")
    return lo, hi


@dataclass(frozen=True)
class ParameterBox:
    """Intervals of factors on the nominal vehicle (module docstring).

    Attributes
    ----------
    mass_factor
        True mass / nominal mass.
    inertia_factor
        True inertia / nominal, **each of Jx, Jy, Jz independently** in this interval.
    attitude_gain_factor
        Factor on the attitude-loop torques (``attitude_gain_scale``).
    tau_motor_factor
        Motor time constant / nominal.
    """

    mass_factor: tuple[float, float] = (1.0, 1.0)
    inertia_factor: tuple[float, float] = (1.0, 1.0)
    attitude_gain_factor: tuple[float, float] = (1.0, 1.0)
    tau_motor_factor: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, _interval(f.name, getattr(self, f.name)))

    @classmethod
    def monte_carlo_default(cls) -> "ParameterBox":
        """The Monte Carlo default ranges (:data:`nniquad.study.scenarios.DEFAULT_RANGES`)."""
        from nniquad.study.scenarios import DEFAULT_RANGES

        return cls(**{k: getattr(DEFAULT_RANGES, k) for k in BOX_KEYS})

    def to_json(self) -> dict[str, list[float]]:
        return {k: list(getattr(self, k)) for k in BOX_KEYS}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> "ParameterBox":
        """Read a box; exactly the keys :data:`BOX_KEYS`."""
        if not isinstance(data, Mapping) or set(data) != set(BOX_KEYS):
            got = sorted(data) if isinstance(data, Mapping) else type(data).__name__
            raise CascadeError(f"a parameter box has exactly the keys {', '.join(BOX_KEYS)}; got {got}")
        return cls(**{k: data[k] for k in BOX_KEYS})

    def scaled(self, s: float) -> "ParameterBox":
        """The box scaled by ``s`` about the nominal point **in log space**: ``[lo^s, hi^s]``.

        Log space keeps every factor positive for any ``s >= 0`` and treats a
        factor and its inverse alike (``tau_motor_factor`` 0.5-2 is symmetric
        there); ``s = 0`` is the nominal point, ``s = 1`` this box.
        """
        if not (isinstance(s, (int, float)) and math.isfinite(s) and s >= 0):
            raise CascadeError(f"box scale must be a finite number >= 0, got {s!r}")
        return ParameterBox(**{k: (getattr(self, k)[0] ** s, getattr(self, k)[1] ** s) for k in BOX_KEYS})

    def contains(self, other: "ParameterBox", rtol: float = 1e-12) -> bool:
        """Whether every interval of ``other`` lies inside this box's."""
        return all(getattr(self, k)[0] <= getattr(other, k)[0] * (1 + rtol)
                   and getattr(other, k)[1] <= getattr(self, k)[1] * (1 + rtol) for k in BOX_KEYS)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper factors of the six point coordinates (:data:`POINT_NAMES`)."""
        iv = [getattr(self, k) for k in BOX_KEYS]
        return (np.array([iv[j][0] for j in _POINT_BOX]), np.array([iv[j][1] for j in _POINT_BOX]))

    def vertices(self) -> np.ndarray:
        """The distinct vertices ``(n_v, 6)`` (a degenerate interval gives one value)."""
        lo, hi = self.bounds()
        axes = [sorted({a, b}) for a, b in zip(lo, hi)]
        return np.array(list(itertools.product(*axes)), float)

    def grid(self, n: int) -> np.ndarray:
        """A tensor grid of ``n`` points per coordinate (ends included), ``(≤ n^6, 6)``; log-spaced."""
        lo, hi = self.bounds()
        axes = [np.unique(np.geomspace(a, b, n)) if b > a else np.array([a]) for a, b in zip(lo, hi)]
        return np.array(list(itertools.product(*axes)), float)


# =============================================================================== the family of sampled loops


@dataclass(frozen=True)
class CascadeFamily:
    """The sampled cascade at many parameter points (batched; index 0 of every array is a point).

    Attributes
    ----------
    points : ndarray (N, 6)
        The parameter points (:data:`POINT_NAMES`).
    state_names
        Plant states then the controller states ``zc_x, zc_y``.
    T
        Sample period [s].
    A_p, B_p : ndarray (N, n_p, n_p), (N, n_p, 2)
        Continuous plant, input the held acceleration command ``a_h`` [m/s²].
    C_p : ndarray (2, n_p)
        Position output.
    A_k, B_k, C_k, D_k
        The NNI controller (continuous; the same at every point: it is the flight code's).
    A_kd, B_kd
        Its exact ZOH equivalent.
    Phi, Gam : ndarray (N, n_p, n_p), (N, n_p, 2)
        The plant's exact ZOH discretisation.
    A_d : ndarray (N, n, n)
        Closed loop ``x_{k+1} = A_d x_k`` (``n = n_p + 2``).
    A0, B : ndarray (N, n, n), (N, n, 2)
        Saturation split ``x_{k+1} = A0 x_k + B a_k`` with ``a_k = sat_L(K x_k)``.
    K : ndarray (2, n)
        The acceleration command ``a_k = K x_k`` before the tilt limit.
    accel_limit : ndarray (N,)
        Norm limit ``L = g_z tan(tilt)`` of ``a_h`` at hover, ``g_z = (m/m̂) g`` [m/s²].
    residual : ndarray (N,)
        ``max |f(x_eq)|`` of each equilibrium.
    W_r, W_a, A_rw
        Motor-command blocks (for :meth:`cascade_at`).
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

    def __len__(self) -> int:
        return self.points.shape[0]

    @cached_property
    def spectral_radius(self) -> np.ndarray:
        """Spectral radius of ``A_d`` at every point (computed once per family: :func:`_take` keeps it)."""
        return np.max(np.abs(np.linalg.eigvals(self.A_d)), axis=-1)

    def cascade_at(self, i: int) -> LinearCascade:
        """The :class:`LinearCascade` of point ``i`` (for the continuous-time margins)."""
        ctx = self.context
        return LinearCascade(
            vehicle=ctx["vehicle"], gains=ctx["gains"], inner=ctx["inner"], motor_lag=True, lin=ctx["lin"],
            plant_states=self.state_names[:-2], rigid_states=ctx["rigid"], controller_states=self.state_names[-2:],
            A_p=self.A_p[i], B_p=self.B_p[i], C_p=self.C_p, A_k=self.A_k, B_k=self.B_k, C_k=self.C_k, D_k=self.D_k,
            W_r=self.W_r[i], W_a=self.W_a[i], A_rw=self.A_rw[i], tau_motor=float(self.tau_motor[i]),
            M_alloc=ctx["M_alloc"])


def _batched_expm(M: np.ndarray) -> np.ndarray:
    return sla.expm(M)  # scipy >= 1.9 exponentiates a stack (..., n, n)


def sampled_family(vehicle: Vehicle, gains: Gains, inner: InnerLoopGains, points: np.ndarray, *,
                   tilt_limit_deg: float = TILT_LIMIT_DEG, rate_hz: float = CONTROL_RATE_HZ) -> CascadeFamily:
    """Linearise and sample the cascade at many parameter points at once.

    One mapped CasADi evaluation of the simulator's Jacobians (at ``±ε`` on the
    held measurement, as :func:`nniquad.analysis.cascade.linearise` does) and
    one stacked ``expm`` give every point's plant; the split into plant and
    controller is that of :func:`nniquad.analysis.cascade.linearise_cascade`
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

    Raises
    ------
    CascadeError
        A point that is not an equilibrium, an inexact split, a bad point.
    """
    T = _period(rate_hz)
    pts = np.atleast_2d(np.asarray(points, float))
    if pts.shape[1] != len(POINT_NAMES) or not np.all(np.isfinite(pts)) or np.any(pts <= 0):
        raise CascadeError(f"parameter points must be positive factors of shape (N, {len(POINT_NAMES)})")
    N = pts.shape[0]
    base = _hover_params(vehicle, gains, inner, tilt_limit_deg, None).with_(run={"sample_hold": 1.0})
    names = [f.name for f in param_layout("nni")]
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
    snames = STATE_NAMES["full"]
    si = {n: i for i, n in enumerate(snames)}
    x_eq = np.tile(initial_state("full", base, (0.0, 0.0)), (N, 1))
    m_true = pv[:, col["plant.m"]]
    g = base.nominal.g
    a_z = g * (1.0 - m_true / base.nominal.m)
    x_eq[:, si["z_int"]] = -a_z / base.inner.altitude_wn_rad_s ** 3
    w_hover = np.sqrt(m_true * nom.g / (4.0 * nom.b))
    for k in range(1, 5):
        x_eq[:, si[f"w{k}"]] = w_hover
    jac = _jacobian_function("full")
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
    ctrl, held, motors = ("zc_x", "zc_y"), ("held_x", "held_y"), ("w1", "w2", "w3", "w4")
    rigid = tuple(n for n in snames if n not in ctrl + held + motors)
    ik, ih = [si[n] for n in ctrl], [si[n] for n in held]
    iw, ir = [si[n] for n in motors], [si[n] for n in rigid]
    ip = ir + iw
    A_k, B_k = J[0][np.ix_(ik, ik)], J[0][np.ix_(ik, ih)]
    C_k, D_k = Y[0][:, ik], Y[0][:, ih]
    # the controller is the flight code's: the same at every point, and it reads no plant state
    for M, name in ((J[:, ik][:, :, ik] - A_k, "A_k"), (J[:, ik][:, :, ih] - B_k, "B_k"),
                    (Y[:, :, ik] - C_k, "C_k"), (Y[:, :, ih] - D_k, "D_k"),
                    (J[:, ik][:, :, ip], "z' from plant"), (Y[:, :, ip], "a_h from plant")):
        if np.max(np.abs(M)) > SPLIT_TOL * max(1.0, float(np.max(np.abs(J[0])))):
            raise CascadeError(f"the horizontal law is not the same velocity-free law at every point ({name})")
    G = np.hstack([C_k, D_k])
    Jpc = J[:, ip][:, :, ik + ih]
    B_full = Jpc @ np.linalg.pinv(G)
    res = np.max(np.abs(Jpc - B_full @ G)) / max(1.0, float(np.max(np.abs(Jpc))))
    if res > SPLIT_TOL:
        raise CascadeError(f"the plant does not see the controller through a_h alone (relative {res:.3g})")
    A_p = J[:, ip][:, :, ip]
    nr = len(ir)
    B_p = B_full
    if np.max(np.abs(B_p[:, :nr])) > SPLIT_TOL * max(1.0, float(np.max(np.abs(B_p)))):
        raise CascadeError("a_h reaches the rigid body other than through the rotors")
    n_p, n_k = len(ip), 2
    C_p = np.zeros((2, n_p))
    C_p[0, rigid.index("x")] = C_p[1, rigid.index("y")] = 1.0
    # exact ZOH of the plant (stacked) and of the controller
    Mz = np.zeros((N, n_p + 2, n_p + 2))
    Mz[:, :n_p, :n_p], Mz[:, :n_p, n_p:] = A_p * T, B_p * T
    E = _batched_expm(Mz)
    Phi, Gam = E[:, :n_p, :n_p], E[:, :n_p, n_p:]
    Ek = sla.expm(np.block([[A_k, B_k], [np.zeros((2, 4))]]) * T)
    A_kd, B_kd = Ek[:2, :2], Ek[:2, 2:]
    n = n_p + n_k
    K = np.hstack([D_k @ C_p, C_k])
    A0 = np.zeros((N, n, n))
    A0[:, :n_p, :n_p] = Phi
    A0[:, n_p:, :n_p] = B_kd @ C_p
    A0[:, n_p:, n_p:] = A_kd
    Bs = np.zeros((N, n, 2))
    Bs[:, :n_p] = Gam
    A_d = A0 + Bs @ K
    A_wr = J[:, iw][:, :, ir]
    W_r = tau[:, None, None] * A_wr
    W_a = tau[:, None, None] * B_p[:, nr:]
    A_rw = J[:, ir][:, :, iw]
    L = (m_true / base.nominal.m) * g * math.tan(math.radians(tilt_limit_deg))
    lin0 = Linearisation("full", snames, x_eq[0], float(residual[0]), J[0], Y[0], base)
    ctx = {"vehicle": vehicle, "gains": gains, "inner": inner, "lin": lin0, "rigid": rigid,
           "M_alloc": allocation_jacobian(base)}
    return CascadeFamily(points=pts, state_names=tuple(rigid + motors + ctrl), T=T, A_p=A_p, B_p=B_p, C_p=C_p,
                         A_k=A_k, B_k=B_k, C_k=C_k, D_k=D_k, A_kd=A_kd, B_kd=B_kd, Phi=Phi, Gam=Gam, A_d=A_d, A0=A0,
                         B=Bs, K=K, accel_limit=L, residual=residual, W_r=W_r, W_a=W_a, A_rw=A_rw, tau_motor=tau,
                         context=ctx)


# =============================================================================== robust Lyapunov LMI


def _sym(M: np.ndarray) -> np.ndarray:
    return 0.5 * (M + np.swapaxes(M, -1, -2))


def contraction_batch(A_d: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``‖P^{1/2} A_d P^{-1/2}‖₂`` for a stack of ``A_d`` (numpy; :func:`nniquad.analysis.sampled.contraction`)."""
    Lt = np.swapaxes(np.linalg.cholesky(_sym(P)), -1, -2)  # P = L Lᵀ, ‖x‖_P = ‖Lᵀ x‖; P may be a stack
    M = Lt @ A_d @ np.linalg.inv(Lt)
    return np.linalg.norm(M, 2, axis=(-2, -1))


@dataclass(frozen=True)
class RobustLyapunov:
    """A common Lyapunov matrix of the sampled cascade at the vertices of a box.

    Attributes
    ----------
    P : ndarray (n, n)
        ``P ≻ 0`` with ``A_d(v)ᵀ P A_d(v) ⪯ ρ² P`` at every vertex (original coordinates).
    rho
        The certified contraction factor per period at the vertices.
    rho_vertices : ndarray
        The numpy contraction factor ``‖P^{1/2} A_d(v) P^{-1/2}‖₂`` of each vertex (each <= ``rho``).
    spectral_radius
        Largest spectral radius over the vertices (the infimum of any common ``ρ``).
    T
        Sample period [s].
    decay_rate_1_s
        ``-ln ρ / T`` [1/s].
    min_eig_P
        Smallest over largest eigenvalue of ``P``.
    ok
        ``P ≻ 0`` and every vertex contracts by at most ``ρ < 1`` (numpy).
    """

    P: np.ndarray
    rho: float
    rho_vertices: np.ndarray
    spectral_radius: float
    T: float
    decay_rate_1_s: float
    min_eig_P: float
    status: str
    ok: bool


def robust_lyapunov(A_v: np.ndarray, T: float, *, S: np.ndarray | None = None, theta: np.ndarray | None = None,
                    rtol: float = CASCADE_LYAPUNOV_RTOL, max_iter: int = 8) -> RobustLyapunov:
    """Common ``P`` with ``A_vᵀ P A_v ⪯ ρ² P`` at every vertex, smallest ``ρ`` by :func:`best_decay` (cvxpy + Clarabel).

    Posed for ``P̃ = Sᵀ P S`` (``S`` the well-scaled coordinates of the nominal
    loop, :func:`nniquad.analysis.sampled._conditioning_transform`), with
    ``I ⪯ P̃ ⪯ t I`` and ``t`` minimised; the answer is re-checked with numpy
    in the original coordinates, and the stated ``ρ`` is the largest numpy
    contraction over the points (:func:`nniquad.analysis.sampled.best_decay`:
    the decay ``1 - rtol`` of the spectral bound first, then a bisection).

    Parameters
    ----------
    A_v : array (n_v, n, n)
        The vertex loops.
    T
        Sample period [s].
    S
        Coordinates of the LMI (default: those of ``A_v[0]``).

    Raises
    ------
    SolverError
        A vertex is unstable, or no ``ρ < 1`` is certified.
    """
    import cvxpy as cp

    A_v = np.asarray(A_v, float)
    nv, n = A_v.shape[0], A_v.shape[1]
    rho_spec = float(np.max(np.abs(np.linalg.eigvals(A_v))))
    if not rho_spec < 1.0:
        raise SolverError(f"robust cascade LMI: a vertex of the box is unstable (spectral radius {rho_spec:.6g})")
    S = _conditioning_transform(A_v[0]) if S is None else S
    Sinv = np.linalg.inv(S)
    Ab = Sinv @ A_v @ S
    th = np.zeros((nv, 0)) if theta is None else np.asarray(theta, float).reshape(nv, -1)
    q = th.shape[1]
    Pk = [cp.Variable((n, n), symmetric=True) for _ in range(q + 1)]
    t = cp.Variable()
    r2 = cp.Parameter(nonneg=True)
    cons = []
    # P(θ) is affine, so P ⪰ I and P ⪯ t I at the corners of the θ-cube hold on the whole cube
    corners = [np.array(c, float) for c in itertools.product((-1.0, 1.0), repeat=q)]
    for c in corners:
        Pc = Pk[0] + sum(c[j] * Pk[j + 1] for j in range(q)) if q else Pk[0]
        cons += [Pc >> np.eye(n), Pc << t * np.eye(n)]
    for i in range(nv):
        Pi = Pk[0] + sum(th[i, j] * Pk[j + 1] for j in range(q)) if q else Pk[0]
        cons += [r2 * Pi - Ab[i].T @ Pi @ Ab[i] >> 0]
    prob = cp.Problem(cp.Minimize(t), cons)

    def solve(rho: float) -> tuple[float, tuple[np.ndarray, np.ndarray, str]] | None:
        r2.value = rho * rho
        got = _solved_affine(prob, Pk, Sinv, A_v, th)
        return None if got is None else (float(np.max(got[1])), got)

    best = best_decay(solve, rho_spec, T, rtol=rtol, max_iter=max_iter)
    if best is None:
        raise SolverError(f"robust cascade LMI: no common P for any decay in (0, {-math.log(rho_spec) / T:.4g}) 1/s")
    rho, (P, rv, status) = best
    wm = witness_margins(P, A_v, th)
    if not wm.ok:  # a witness whose margins do not clear rounding is refused, not stated
        raise SolverError(f"robust cascade LMI: the answer's margins do not clear rounding (1 - rho = "
                          f"{1 - wm.rho:.3g} vs bound {wm.rho_bound:.3g}; min eig {wm.definite:.3g} vs "
                          f"{wm.definite_bound:.3g})")
    return RobustLyapunov(P=P, rho=wm.rho, rho_vertices=rv, spectral_radius=rho_spec, T=T,
                          decay_rate_1_s=-math.log(wm.rho) / T, min_eig_P=wm.min_eig_ratio, status=status, ok=True)


def _solved_affine(prob: Any, Pk: Sequence[Any], Sinv: np.ndarray, A_v: np.ndarray,
                   theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, str] | None:
    """Solve for an affine ``P(θ)`` posed in scaled coordinates; ``(P_k stacked, contraction per point, status)``.

    The answer is mapped back to the original coordinates and its contraction at
    every point computed with numpy; ``None`` when the solver fails or ``P(θ)`` is
    not positive definite at a point.
    """
    status = solve_with_clarabel(prob, Pk[0])
    if status is None:
        return None
    Po = np.stack([_sym(Sinv.T @ _sym(V.value) @ Sinv) for V in Pk])
    try:
        return Po, contraction_batch(A_v, _affine(Po, theta)), status
    except np.linalg.LinAlgError:  # P(θ) not positive definite at a point
        return None


def reach_lyapunov(A_v: np.ndarray, T: float, K: np.ndarray, L: float, rho: float, *,
                   theta: np.ndarray | None = None, eps: float = 1e-6) -> RobustLyapunov | None:
    """A horizontal axis's ``P(θ)`` with the widest linear-zone reach, at a given contraction ``rho``.

    The ellipsoid ``{xᵀ P(θ) x <= 1}`` lies where the tilt limit is inactive iff
    ``K P(θ)⁻¹ Kᵀ <= L²``, i.e. ``[[P(θ), Kᵀ], [K, L²]] ⪰ 0`` (Schur), which is
    linear in ``P``.  A start ``r e_0`` (position offset, all else at hover) is
    inside iff ``r² P(θ)_00 <= 1``, so the reach is widest when the largest
    ``P(θ)_00`` over the θ-cube (its corners: ``P`` is affine) is smallest.  That
    is minimised subject to the decrease ``A_vᵀ P A_v ⪯ ρ² P`` and ``P ⪰ eps I``
    at the LMI points (cvxpy + Clarabel, in diagonally balanced coordinates).
    The answer is re-checked with numpy in the original coordinates, and its
    stated ``ρ`` is its numpy contraction (:func:`robust_lyapunov`).

    Parameters
    ----------
    A_v : array (n_v, n, n)
        The loops at the LMI points.
    T
        Sample period [s].
    K : array (1, n)
        The axis's acceleration command ``a = K x`` before the tilt limit.
    L
        The tilt limit as an acceleration bound [m/s²].
    rho
        Target contraction per period (< 1).
    theta : array (n_v, q)
        The points' coordinates in the θ-cube.
    eps
        Smallest eigenvalue of ``P`` in the balanced coordinates.

    Returns
    -------
    RobustLyapunov or None
        ``None`` when the solver fails or its answer does not contract (< 1) with ``P ≻ 0``.
    """
    import cvxpy as cp

    A_v = np.asarray(A_v, float)
    nv, n = A_v.shape[0], A_v.shape[1]
    th = np.zeros((nv, 0)) if theta is None else np.asarray(theta, float).reshape(nv, -1)
    q = th.shape[1]
    _, (scale, _) = sla.matrix_balance(A_v[0], permute=False, separate=True)
    S, Sinv = np.diag(scale), np.diag(1.0 / scale)
    Ab = Sinv @ A_v @ S
    KS = np.asarray(K, float).reshape(1, n) @ S
    e0 = Sinv[:, 0]  # x_0 = r e_0 in the balanced coordinates
    Pk = [cp.Variable((n, n), symmetric=True) for _ in range(q + 1)]
    top = cp.Variable()
    cons = []
    for c in itertools.product((-1.0, 1.0), repeat=q):
        Pc = Pk[0] + sum(c[j] * Pk[j + 1] for j in range(q)) if q else Pk[0]
        cons += [Pc >> eps * np.eye(n), e0 @ Pc @ e0 <= top]
    for i in range(nv):
        Pi = Pk[0] + sum(th[i, j] * Pk[j + 1] for j in range(q)) if q else Pk[0]
        cons += [rho * rho * Pi - Ab[i].T @ Pi @ Ab[i] >> 0, cp.bmat([[Pi, KS.T], [KS, np.array([[L * L]])]]) >> 0]
    prob = cp.Problem(cp.Minimize(top), cons)
    solved = _solved_affine(prob, Pk, Sinv, A_v, th)
    if solved is None:
        return None
    Po, rv, status = solved
    wm = witness_margins(Po, A_v, th)
    if not wm.ok:  # no contraction, or margins below rounding: not a witness
        return None
    rho_spec = float(np.max(np.abs(np.linalg.eigvals(A_v))))
    return RobustLyapunov(P=Po, rho=wm.rho, rho_vertices=rv, spectral_radius=rho_spec, T=T,
                          decay_rate_1_s=-math.log(wm.rho) / T, min_eig_P=wm.min_eig_ratio, status=status, ok=True)


def _affine(Pk: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``P(θ) = P_0 + Σ θ_j P_j`` for every row of ``theta`` (``Pk`` stacked ``(q + 1, n, n)``)."""
    theta = np.atleast_2d(theta)
    return Pk[0][None] + np.einsum("ij,jkl->ikl", theta, Pk[1:]) if Pk.shape[0] > 1 else \
        np.broadcast_to(Pk[0], (theta.shape[0],) + Pk.shape[1:])


@dataclass(frozen=True)
class WitnessMargins:
    """What an affine ``P(θ)`` certifies at the LMI points, with the rounding bound of each strict inequality.

    Attributes
    ----------
    rho
        Largest numpy contraction ``‖P(θ)^{1/2} A(θ) P(θ)^{-1/2}‖₂`` over the points (``inf``: ``P`` not
        positive definite at a point).
    rho_bound
        Largest rounding bound of that contraction over the points
        (:func:`nniquad.analysis.lmi.checks.contraction_rounding_bound`).
    definite
        Smallest eigenvalue of the diagonally scaled ``P(θ)`` over the corners of the θ-cube (``P`` is affine,
        so ``P ≻ 0`` there holds on the whole cube).
    definite_bound
        Its rounding bound (:func:`nniquad.analysis.lmi.checks.definite_margin`).
    min_eig_ratio
        Smallest ``λ_min / λ_max`` of ``P(θ)`` over the corners (unscaled; a record of the conditioning).
    rho_all : ndarray
        The contraction at every point.
    """

    rho: float
    rho_bound: float
    definite: float
    definite_bound: float
    min_eig_ratio: float
    rho_all: np.ndarray

    @property
    def ok(self) -> bool:
        """``ρ < 1`` and ``P ≻ 0``, each with a margin above its rounding bound."""
        return bool(self.rho < 1.0 and 1.0 - self.rho > self.rho_bound and self.definite > self.definite_bound)


def witness_margins(Pk: np.ndarray, A_v: np.ndarray, theta: np.ndarray) -> WitnessMargins:
    """:class:`WitnessMargins` of ``P(θ) = P_0 + Σ θ_j P_j`` for the loops ``A_v`` at the points ``theta`` (numpy)."""
    Pk = np.asarray(Pk, float)
    th = np.atleast_2d(np.asarray(theta, float)).reshape(A_v.shape[0], -1)
    q = th.shape[1]
    corners = np.array(list(itertools.product((-1.0, 1.0), repeat=q)), float).reshape(-1, q)
    Pc = _affine(Pk, corners)
    lam, lam_bound = lmi_checks.definite_margin(Pc)
    ev = np.linalg.eigvalsh(_sym(Pc))
    ratio = float(np.min(ev[:, 0] / ev[:, -1]))
    P = _affine(Pk, th)
    try:
        rv = contraction_batch(A_v, P)
    except np.linalg.LinAlgError:  # P(θ) not positive definite at a point
        return WitnessMargins(math.inf, math.inf, float(np.min(lam)), float(np.max(lam_bound)), ratio, np.array([]))
    bound = lmi_checks.contraction_rounding_bound(A_v, P, rv)
    return WitnessMargins(rho=float(np.max(rv)), rho_bound=float(np.max(bound)), definite=float(np.min(lam)),
                          definite_bound=float(np.max(lam_bound)), min_eig_ratio=ratio, rho_all=rv)


@dataclass(frozen=True)
class GridCheck:
    """The numpy check of a Lyapunov matrix on a grid inside the box (covers the grid points only).

    Attributes
    ----------
    size
        Number of grid points.
    points_per_axis
        Grid points per coordinate.
    worst_rho
        Largest contraction factor ``‖P^{1/2} A_d(θ) P^{-1/2}‖₂`` over the grid.
    worst_margin
        ``1 - worst_rho`` (positive: ``P`` decreases at every grid point).
    worst_point
        A point where ``worst_rho`` is attained (many points may tie to rounding: a check compares the value
        at a stated point, never which of the tied points an argmax picks).
    worst_spectral_radius
        Largest spectral radius of ``A_d`` over the grid (at most the contraction: implied by ``rho < 1``).
    worst_spectral_point
        A point where it is attained.
    rounding_bound
        Largest rounding bound of the contraction over the grid
        (:func:`nniquad.analysis.lmi.checks.contraction_rounding_bound`).
    margin_over_bound
        Smallest ``(1 - rho) / bound`` over the grid: ``rho < 1`` is certified at every point iff it exceeds 1.
    rho_all, spectral_all : ndarray
        The contraction and the spectral radius at every grid point (not serialised).
    """

    size: int
    points_per_axis: int
    worst_rho: float
    worst_margin: float
    worst_point: tuple[float, ...]
    worst_spectral_radius: float
    worst_spectral_point: tuple[float, ...]
    rounding_bound: float = math.nan
    margin_over_bound: float = math.nan
    rho_all: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False, compare=False)
    spectral_all: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False, compare=False)

    @property
    def ok(self) -> bool:
        """Every grid point contracts with a margin above rounding (and so has spectral radius < 1)."""
        return bool(self.worst_rho < 1.0 and self.worst_spectral_radius < 1.0 and self.margin_over_bound > 1.0)

    def to_json(self) -> dict[str, Any]:
        return {"size": self.size, "points_per_axis": self.points_per_axis, "worst_rho": self.worst_rho,
                "worst_margin": self.worst_margin, "worst_point": dict(zip(POINT_NAMES, self.worst_point)),
                "worst_spectral_radius": self.worst_spectral_radius,
                "worst_spectral_point": dict(zip(POINT_NAMES, self.worst_spectral_point)),
                "rounding_bound": self.rounding_bound, "margin_over_bound": self.margin_over_bound, "ok": self.ok}


def grid_check(family: CascadeFamily, P: np.ndarray, points_per_axis: int) -> GridCheck:
    """Contraction factor of ``P`` and spectral radius at every point of ``family`` (numpy).

    The vertex LMIs of :func:`robust_lyapunov` do not extend to the interior of
    the box (``A_d`` is not affine in the parameters); this check covers the
    grid points, and only them.  Each point's ``1 - rho`` is compared with its
    rounding bound (:func:`nniquad.analysis.lmi.checks.contraction_rounding_bound`).
    """
    rho = contraction_batch(family.A_d, P)
    sr = family.spectral_radius
    bound = np.asarray(lmi_checks.contraction_rounding_bound(family.A_d, P, rho), float).reshape(rho.shape)
    i, j = int(np.argmax(rho)), int(np.argmax(sr))
    return GridCheck(size=len(family), points_per_axis=int(points_per_axis), worst_rho=float(rho[i]),
                     worst_margin=float(1.0 - rho[i]), worst_point=tuple(float(v) for v in family.points[i]),
                     worst_spectral_radius=float(sr[j]), worst_spectral_point=tuple(float(v) for v in family.points[j]),
                     rounding_bound=float(np.max(bound)), margin_over_bound=float(np.min((1.0 - rho) / bound)),
                     rho_all=rho, spectral_all=np.asarray(sr, float))


def point_index(points: np.ndarray, point: Sequence[float], rtol: float = 1e-9) -> int | None:
    """Index of ``point`` among the rows of ``points`` (within ``rtol``, relative), or ``None``."""
    p = np.asarray(point, float).reshape(1, -1)
    if p.shape[1] != points.shape[1] or not np.all(np.isfinite(p)):
        return None
    hit = np.flatnonzero(np.all(np.abs(points - p) <= rtol * np.abs(p), axis=1))
    return int(hit[0]) if hit.size else None


# =============================================================================== decoupled subsystems

#: The fixed change of the rotor coordinates: collective, roll pair, pitch pair, yaw (orthonormal; '+' layout
#: of :func:`nniquad.control.inner_loops.allocate`: roll from w4 - w2, pitch from w1 - w3).
_ROTOR_MODES = np.array([[0.5, 0.5, 0.5, 0.5],
                         [0.0, -1 / math.sqrt(2), 0.0, 1 / math.sqrt(2)],
                         [1 / math.sqrt(2), 0.0, -1 / math.sqrt(2), 0.0],
                         [-0.5, 0.5, -0.5, 0.5]])
_ROTOR_MODE_NAMES = ("m_collective", "m_roll", "m_pitch", "m_yaw")
#: The subsystems of the cascade at hover after :func:`mode_transform` (position first, controller state
#: last in each horizontal axis, the same order on both axes).
SUBSYSTEMS: dict[str, tuple[str, ...]] = {
    "x": ("x", "x_dot", "theta", "theta_dot", "m_pitch", "zc_x"),
    "y": ("y", "y_dot", "phi", "phi_dot", "m_roll", "zc_y"),
    "altitude": ("z", "z_dot", "z_int", "m_collective"),
    "yaw": ("psi", "psi_dot", "m_yaw"),
}


def mode_transform(state_names: Sequence[str]) -> tuple[np.ndarray, tuple[str, ...]]:
    """The fixed orthogonal map ``ζ = T_m x`` to the coordinates of :data:`SUBSYSTEMS` (rotor modes, permuted).

    Returns ``T_m`` (rows in the order x, y, altitude, yaw subsystems) and the new state names.
    """
    names = list(state_names)
    n = len(names)
    R = np.eye(n)
    iw = [names.index(f"w{k}") for k in range(1, 5)]
    R[np.ix_(iw, iw)] = _ROTOR_MODES
    mode_names = list(names)
    for i, m in zip(iw, _ROTOR_MODE_NAMES):
        mode_names[i] = m
    order = [mode_names.index(s) for sub in SUBSYSTEMS.values() for s in sub]
    if sorted(order) != list(range(n)):
        raise CascadeError("the subsystems do not partition the cascade's states")
    return R[order], tuple(mode_names[i] for i in order)


def _blocks() -> dict[str, slice]:
    out, k = {}, 0
    for name, sub in SUBSYSTEMS.items():
        out[name] = slice(k, k + len(sub))
        k += len(sub)
    return out


def coupling(family: CascadeFamily) -> float:
    """Largest coupling between the subsystems of ``T_m A_d T_mᵀ``, relative (diagonal balancing of the nominal loop).

    Zero in exact arithmetic at hover (the altitude, yaw and the two horizontal
    axes decouple at first order); what remains is the ``O(ε²)`` error of the
    symmetric-mean Jacobian (:mod:`nniquad.analysis.cascade`), about ``1e-12``.
    """
    Tm, _ = mode_transform(family.state_names)
    Z = Tm @ family.A_d @ Tm.T
    _, (s, _) = sla.matrix_balance(Z[0], permute=False, separate=True)
    Zb = Z / s[None, :, None] * s[None, None, :]
    mask = np.ones(Z.shape[1:], bool)
    for sl in _blocks().values():
        mask[sl, sl] = False
    return float(np.max(np.abs(Zb[:, mask])) / max(np.max(np.abs(Zb)), 1.0))


def _subsystem(family: CascadeFamily, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A_d, A0, B, K)`` of one subsystem at every point (B and K: the axis's own input/command; else None)."""
    Tm, _ = mode_transform(family.state_names)
    sl = _blocks()[name]
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


def box_coordinates(box: ParameterBox, points: np.ndarray) -> np.ndarray:
    """Normalised coordinates ``θ ∈ [-1, 1]`` (log factor, centred) of the non-degenerate box directions."""
    lo, hi = box.bounds()
    keep = hi > lo
    llo, lhi = np.log(lo[keep]), np.log(hi[keep])
    return (2.0 * np.log(np.atleast_2d(points)[:, keep]) - (llo + lhi)) / (lhi - llo)


def _relevance_points(box: ParameterBox) -> np.ndarray:
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
        A = _subsystem(fam, name)[0]
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


def relevant_coordinates(vehicle: Vehicle, gains: Gains, inner: InnerLoopGains, box: ParameterBox, *,
                         tilt_limit_deg: float, rate_hz: float, tol: float = RELEVANCE_TOL) -> dict[str, tuple[int, ...]]:
    """Which point coordinates change each subsystem's ``A_d`` (moving one coordinate to each end of the box).

    A coordinate that changes a subsystem by less than ``tol`` (relative) is
    left out of that subsystem's LMI; the grid check on the full 19-state loop
    (:func:`grid_check`) is done with all six.
    """
    fam = sampled_family(vehicle, gains, inner, _relevance_points(box), tilt_limit_deg=tilt_limit_deg,
                         rate_hz=rate_hz)
    return _relevance_from(fam, box, tol)


def _coords(box: ParameterBox, points: np.ndarray, dims: Sequence[int]) -> np.ndarray:
    lo, hi = box.bounds()
    d = list(dims)
    llo, lhi = np.log(lo[d]), np.log(hi[d])
    return (2.0 * np.log(np.atleast_2d(points)[:, d]) - (llo + lhi)) / (lhi - llo)


def _subgrid(box: ParameterBox, dims: Sequence[int], n: int) -> np.ndarray:
    """A grid of ``n`` points per coordinate over ``dims`` (log-spaced), the other coordinates nominal (1)."""
    lo, hi = box.bounds()
    axes = [np.geomspace(lo[j], hi[j], n) if j in dims else np.array([1.0]) for j in range(6)]
    return np.array(list(itertools.product(*axes)), float)


# =============================================================================== region of attraction


@dataclass(frozen=True)
class RobustROA:
    """The region of attraction of the saturated sampled cascade's horizontal axes (both axes together).

    For each axis ``a ∈ {x, y}``: ``W_a(θ) = W_a0 + Σ θ_j W_aj`` (``P_a = W_a⁻¹``),
    ``Z_a(θ)`` (``G_a = Z_a W_a⁻¹``), one scalar multiplier ``S = 1/t`` shared by the
    axes (the vector sector condition of the norm limit needs a scalar), the
    decay factor ``rho`` per period inside the region, the acceleration limit
    ``L`` [m/s²] and the reach [m].  ``Wk[a]`` stacks ``(q_a + 1, 6, 6)``;
    ``dims[a]`` are the point coordinates of ``θ``.
    """

    Wk: dict[str, np.ndarray]
    Zk: dict[str, np.ndarray]
    S: float
    rho: float
    L: float
    reach_m: float
    dims: dict[str, tuple[int, ...]]
    status: str


def _roa_matrices(A_d: np.ndarray, B: np.ndarray, K: np.ndarray, W: np.ndarray, Z: np.ndarray, S: float,
                  rho: float, L: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """numpy forms, in the original variables, of the decrease and inclusion conditions (stacked over points).

    Decrease (must be ⪯ 0): ``[A_d, -B]ᵀ P [A_d, -B] - [[ρ² P, -Gᵀ T], [-T G, 2T]]`` with ``P = W⁻¹``,
    ``G = Z P``, ``T = 1/S``: then ``V(x⁺) - ρ² V(x) <= 2 ψᵀ T (ψ - G x) <= 0`` in the region.
    Inclusion (must be >= 0): ``L² - (K - G) W (K - G)ᵀ``.
    """
    P = np.linalg.inv(_sym(W))
    G = Z @ P
    Tm = 1.0 / S
    M = np.concatenate([A_d, -np.broadcast_to(B, A_d.shape[:-2] + B.shape[-2:])], axis=-1)
    n = A_d.shape[-1]
    R = np.zeros(M.shape[:-2] + (n + 1, n + 1))
    R[..., :n, :n] = rho * rho * P
    R[..., :n, n:] = -np.swapaxes(G, -1, -2) * Tm
    R[..., n:, :n] = -G * Tm
    R[..., n:, n:] = 2.0 * Tm
    dec = np.swapaxes(M, -1, -2) @ P @ M - R
    KG = K - G
    inc = L * L - (KG @ W @ np.swapaxes(KG, -1, -2))[..., 0, 0]
    return _sym(dec), inc, P


def robust_region_of_attraction(axes: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                                L: float, rho: float, *, r_cap: float = 1e3) -> RobustROA:
    """Largest certified position offset under the norm tilt limit, common over the LMI points (cvxpy + Clarabel).

    ``axes[a] = (A_d, B, K, theta)`` at the LMI points of axis ``a`` (``theta`` their
    normalised coordinates).  At each point, ``x_{k+1} = A_d x_k - B ψ_k`` with the
    dead zone ``ψ = v - sat_L(v)`` of the 2-D command ``v = K x`` (both axes).  The
    LMIs (``W`` the inverse Lyapunov matrix, ``Z = G W``, ``S = T⁻¹``, Schur form):

    * decrease at every LMI point: ``[[ρ² W, -Zᵀ, W A_dᵀ], [-Z, 2S, -S Bᵀ], [A_d W, -B S, W]] ⪰ 0``;
    * inclusion ``[[W, (K W - Z)ᵀ], [K W - Z, L²]] ⪰ 0`` and start
      ``[[W, r e_1], [r e_1ᵀ, 1]] ⪰ 0`` at the corners of the θ-cube (both affine in
      ``θ``, so they hold on the whole cube),

    ``r`` maximised.  The decrease matrices split by axis (block-diagonal ``A_d``,
    ``B``, ``G`` and a scalar ``T``), so the 2-D condition is the pair of axis
    conditions; the inclusion of the 2-D command in the norm ball is the larger
    of the axis inclusions.  Solved in scaled units: position in ``L/|K_0|``,
    the other states balanced (:func:`scipy.linalg.matrix_balance`), ``ψ`` in ``L``.
    """
    import cvxpy as cp

    W, Z, cons, data = {}, {}, [], {}
    S = cp.Variable()
    r = cp.Variable()
    for a, (A_d, B, K, th) in axes.items():
        th = np.atleast_2d(th)
        q = th.shape[1]
        n = A_d.shape[-1]
        _, (dsc, _) = sla.matrix_balance(A_d[0], permute=False, separate=True)
        d = dsc / dsc[0] * (L / abs(float(K[0, 0])))
        D, Di = np.diag(d), np.diag(1.0 / d)
        At = Di @ A_d @ D
        Bt = (Di @ B) * L
        Kt = (K @ D) / L
        Wk = [cp.Variable((n, n), symmetric=True) for _ in range(q + 1)]
        Zk = [cp.Variable((1, n)) for _ in range(q + 1)]
        aff = lambda V, c: V[0] + sum(c[j] * V[j + 1] for j in range(q)) if q else V[0]  # noqa: E731
        e1 = np.zeros((n, 1))
        e1[0, 0] = 1.0
        for c in itertools.product((-1.0, 1.0), repeat=q):
            Wc, Zc = aff(Wk, c), aff(Zk, c)
            inc = cp.bmat([[Wc, (Kt @ Wc - Zc).T], [Kt @ Wc - Zc, np.ones((1, 1))]])
            st = cp.bmat([[Wc, (r / d[0]) * e1], [(r / d[0]) * e1.T, np.ones((1, 1))]])
            cons += [0.5 * (inc + inc.T) >> 0, 0.5 * (st + st.T) >> 0]
        for i in range(At.shape[0]):
            Wi, Zi = aff(Wk, th[i]), aff(Zk, th[i])
            Ai, Bi = At[i], Bt if Bt.ndim == 2 else Bt[i]
            M = cp.bmat([[rho * rho * Wi, -Zi.T, Wi @ Ai.T], [-Zi, 2 * S * np.ones((1, 1)), -S * Bi.T],
                         [Ai @ Wi, -S * Bi, Wi]])
            cons.append(0.5 * (M + M.T) >> 1e-9 * np.eye(2 * n + 1))
        W[a], Z[a], data[a] = Wk, Zk, (D, q)
    cons += [S >= 1e-9, r >= 0, r <= r_cap]
    prob = cp.Problem(cp.Maximize(r), cons)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            prob.solve(solver=cp.CLARABEL)
    except cp.error.SolverError as exc:
        raise SolverError(f"cascade region of attraction: the solver failed ({exc})") from None
    if prob.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or S.value is None:
        raise SolverError(f"cascade region of attraction: no solution ({prob.status})")
    # back to the original variables: W = D W~ D, Z = G W = L Z~ D (G = L G~ D^-1), S = L² S~ (T = T~ / L²)
    Wk_o = {a: np.stack([_sym(data[a][0] @ V.value @ data[a][0]) for V in W[a]]) for a in axes}
    Zk_o = {a: np.stack([L * (V.value @ data[a][0]) for V in Z[a]]) for a in axes}
    return RobustROA(Wk=Wk_o, Zk=Zk_o, S=float(S.value) * L * L, rho=float(rho), L=float(L),
                     reach_m=float(r.value), dims={}, status=str(prob.status))


#: Rounds of cutting planes of the generalised-sector LMI (failing grid points added to the LMI points).
GSC_CUTTING_ROUNDS = 2
#: Failing grid points added per axis and round (the worst ones).
GSC_CUTTING_POINTS = 8


def _roa_decrease(roa: RobustROA, axes) -> dict[str, np.ndarray]:
    """Largest relative eigenvalue of the decrease matrix at every point, per axis (< 0 required)."""
    out = {}
    for a, (A_d, B, K, th) in axes.items():
        Wt = _affine(roa.Wk[a], th)
        Zt = roa.Zk[a][0][None] + np.einsum("ij,jkl->ikl", np.atleast_2d(th), roa.Zk[a][1:]) \
            if roa.Zk[a].shape[0] > 1 else np.broadcast_to(roa.Zk[a][0], (Wt.shape[0], 1, Wt.shape[-1]))
        dec, _, _ = _roa_matrices(A_d, B, K, Wt, Zt, roa.S, roa.rho, roa.L)
        de = np.linalg.eigvalsh(dec)
        out[a] = de[:, -1] / np.max(np.abs(de), axis=-1)
    return out


def roa_recheck(roa: RobustROA, axes: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                reach_m: float | None = None) -> dict[str, float]:
    """numpy re-check of the region of attraction at the given points (each axis: ``(A_d, B, K, theta)``).

    Returns the worst (largest) relative eigenvalue of the decrease matrices
    (must be < 0), the worst inclusion margin ``1 - (K-G)W(K-G)ᵀ/L²`` (>= 0), the
    smallest relative eigenvalue of ``W`` (> 0) and the worst level ``r² P_00``
    of the start point at the stated reach (<= 1).
    """
    r = roa.reach_m if reach_m is None else reach_m
    worst = {"decrease_max_eig": -math.inf, "inclusion_margin": math.inf, "min_eig_W": math.inf,
             "start_level": -math.inf}
    for a, (A_d, B, K, th) in axes.items():
        Wt = _affine(roa.Wk[a], th)
        Zt = roa.Zk[a][0][None] + np.einsum("ij,jkl->ikl", np.atleast_2d(th), roa.Zk[a][1:]) \
            if roa.Zk[a].shape[0] > 1 else np.broadcast_to(roa.Zk[a][0], (Wt.shape[0], 1, Wt.shape[-1]))
        ev = np.linalg.eigvalsh(Wt)
        worst["min_eig_W"] = min(worst["min_eig_W"], float(np.min(ev[:, 0] / ev[:, -1])))
        if np.min(ev[:, 0]) <= 0:
            return {**worst, "decrease_max_eig": math.inf}
        dec, inc, P = _roa_matrices(A_d, B, K, Wt, Zt, roa.S, roa.rho, roa.L)
        de = np.linalg.eigvalsh(dec)
        scale = np.max(np.abs(de), axis=-1)
        worst["decrease_max_eig"] = max(worst["decrease_max_eig"], float(np.max(de[:, -1] / scale)))
        worst["inclusion_margin"] = min(worst["inclusion_margin"], float(np.min(inc)) / roa.L ** 2)
        worst["start_level"] = max(worst["start_level"], float(np.max(r * r * P[:, 0, 0])))
    return worst


# =============================================================================== the certificate section

#: Points per coordinate of each subsystem's Lyapunov LMI (the vertices and the centre); the numpy grid
#: check uses :data:`nniquad.config.CASCADE_GRID_POINTS_PER_AXIS` (other points than these, but the vertices).
LMI_POINTS_PER_AXIS = 3
_MODEL = "full (linearised at hover, 19 states: rigid body, altitude PID, yaw, attitude PD, motors, NNI)"
_FORM = "P(θ) = P0 + Σ θ_j P_j per decoupled subsystem, θ ∈ [-1, 1] the log factors normalised on the box"
_COVERAGE = ("the LMI holds at the LMI points (grid of 3 per coordinate: vertices, centre, mid-faces); "
             "the interior is checked with numpy at the grid points only")
_ROA_NOTE = ("linear_zone: the level set x'P(θ)x <= c(θ) of the grid-checked Lyapunov matrix inside "
             "‖K x‖ <= u0 (the generalised sector condition with G = 0: no saturation inside, so it is invariant "
             "and contracts by the grid's worst rho); gsc: discrete generalised sector condition, scalar "
             "multiplier. u0 = (min mass factor) g tan(tilt); start: position offset in any direction, "
             "all else at hover, controller state 0")
_MARGIN_POINTS = "vertices of the box in the coordinates that reach the horizontal axes"
_MARGIN_MODEL = "Padé (order 2) model of the sampling, continuous time (nniquad.analysis.fast_margins)"
#: Wall-clock seconds of the parts of the last :func:`cascade_section` (not stored in the section: not checkable).
last_timings: dict[str, float] = {}


def _assemble_P(lyap: Mapping[str, RobustLyapunov], dims: Mapping[str, Sequence[int]], box: ParameterBox,
                points: np.ndarray, state_names: Sequence[str]) -> np.ndarray:
    """The full Lyapunov matrix ``T_mᵀ diag(P_x, P_y, P_alt, P_yaw)(θ) T_m`` at every point."""
    Tm, _ = mode_transform(state_names)
    n = Tm.shape[0]
    Pz = np.zeros((points.shape[0], n, n))
    for name, sl in _blocks().items():
        Pz[:, sl, sl] = _affine(lyap[name].P, _coords(box, points, dims[name]))
    return Tm.T @ Pz @ Tm


def _mirror(x: tuple, y: tuple, rtol: float = 1e-6) -> np.ndarray | None:
    """Signs ``d`` with ``A_y ≈ D A_x D`` and ``K_y ≈ K_x D`` (``D = diag(d)``) at every LMI point, or ``None``.

    A vehicle with equal roll and pitch data has mirrored x and y blocks (roll and
    pitch move the position with opposite signs; the linearisation leaves
    differences of about 1e-10); then ``D P_x D`` is a candidate Lyapunov matrix
    of y, which :func:`_mirrored` re-checks with numpy on y's own loops, so
    ``rtol`` only decides whether the candidate is tried.
    """
    (Ax, Kx, thx), (Ay, Ky, thy) = x, y
    if Ax.shape != Ay.shape or thx.shape != thy.shape or not np.allclose(thx, thy, rtol=0, atol=1e-15):
        return None
    tol = rtol * max(float(np.max(np.abs(Ax))), 1.0)
    for signs in itertools.product((1.0, -1.0), repeat=Ax.shape[1] - 1):
        d = np.array((1.0,) + signs)
        if np.max(np.abs(Ay - d[:, None] * Ax * d[None, :])) <= tol and np.max(np.abs(Ky - Kx * d)) <= tol:
            return d
    return None


def _mirrored(lx: RobustLyapunov, d: np.ndarray, A_v: np.ndarray, theta: np.ndarray) -> RobustLyapunov | None:
    """``D P_x(θ) D`` as y's Lyapunov matrix, its contraction re-checked with numpy on y's loops (``None``: it fails)."""
    P = d[None, :, None] * lx.P * d[None, None, :]
    wm = witness_margins(P, A_v, theta)
    if not wm.ok:
        return None
    return replace(lx, P=P, rho=wm.rho, rho_vertices=wm.rho_all,
                   spectral_radius=float(np.max(np.abs(np.linalg.eigvals(A_v)))),
                   decay_rate_1_s=-math.log(wm.rho) / lx.T, min_eig_P=wm.min_eig_ratio,
                   status=f"mirrored from x ({lx.status})")


def tilt_accel_limit(vehicle: Vehicle, box: ParameterBox, tilt_limit_deg: float) -> float:
    """``u0 = (lowest mass factor) g tan(tilt)`` [m/s²]: the tilt limit as a bound on the horizontal command over the box."""
    return box.mass_factor[0] * vehicle.g * math.tan(math.radians(tilt_limit_deg))


def _block_loops(fam: CascadeFamily, box: ParameterBox, pts: Mapping[str, np.ndarray],
                 dims: Mapping[str, Sequence[int]]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each subsystem's loops ``A`` at its LMI points and their θ coordinates, from a family stacked as
    ``[nominal, LMI points of each subsystem in SUBSYSTEMS order, ...]``."""
    out, k = {}, 1
    for name in SUBSYSTEMS:
        m = pts[name].shape[0]
        out[name] = (_subsystem(fam, name)[0][k:k + m], _coords(box, pts[name], dims[name]))
        k += m
    return out


def _certify_box(vehicle, gains, inner, box, *, tilt_limit_deg, rate_hz, dims, grid_n):
    """The subsystem LMIs at the LMI points and the full grid check; raises SolverError when not certified.

    The horizontal axes get two candidates: the fastest decay (:func:`robust_lyapunov`) and the widest
    linear-zone reach at a slightly slower one (:func:`reach_lyapunov`); the widest that passes the grid
    check is kept.
    """
    pts = {name: _subgrid(box, dims[name], LMI_POINTS_PER_AXIS) for name in SUBSYSTEMS}
    allp = np.vstack([np.ones((1, 6))] + list(pts.values()) + [box.grid(grid_n)])
    fam = sampled_family(vehicle, gains, inner, allp, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz)
    L = tilt_accel_limit(vehicle, box, tilt_limit_deg)
    lyap, wide, k = {}, {}, 1
    blocks: dict[str, tuple] = {}
    for name in SUBSYSTEMS:
        m = pts[name].shape[0]
        A, _, _, K = _subsystem(fam, name)
        A, th = A[k:k + m], _coords(box, pts[name], dims[name])
        blocks[name] = (A, K, th)
        d = _mirror(blocks["x"], blocks[name]) if name == "y" else None
        # y is x in mirrored coordinates: the mirrored answers, re-checked on y's own loops, else solved
        mirrored = _mirrored(lyap["x"], d, A, th) if d is not None else None
        lyap[name] = mirrored or robust_lyapunov(A, fam.T, theta=th)
        if K is not None:  # a horizontal axis: also the widest reach at a slightly slower decay
            rho = math.exp(-CASCADE_REACH_DECAY_FRACTION * lyap[name].decay_rate_1_s * fam.T)
            wide[name] = (_mirrored(wide["x"], d, A, th) if mirrored is not None and wide["x"] is not None
                          else None) or reach_lyapunov(A, fam.T, K, L, rho, theta=th)
        k += m
    grid_fam = _take(fam, np.arange(k, len(fam)))
    lmi_fam = _take(fam, np.arange(1, k))
    candidates = [lyap]
    if all(wide.get(a) is not None for a in ("x", "y")):
        widened = {**lyap, **wide}
        if linear_zone_reach(widened, dims, box, lmi_fam, L) > linear_zone_reach(lyap, dims, box, lmi_fam, L):
            candidates.insert(0, widened)
    for cand in candidates:  # the widest reach whose grid check passes, else the fastest decay
        gc = grid_check(grid_fam, _assemble_P(cand, dims, box, grid_fam.points, fam.state_names), grid_n)
        if gc.ok:
            return fam, pts, cand, grid_fam, gc
    raise SolverError(f"cascade grid check fails: contraction {gc.worst_rho:.6g} at {gc.worst_point}")


def _take(fam: CascadeFamily, idx: np.ndarray) -> CascadeFamily:
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


@dataclass(frozen=True)
class BoxSearch:
    """The result of :func:`widest_box`: the widest scale certified and the certificate's parts there.

    Attributes
    ----------
    scale
        Widest scale ``s`` of the base box certified (log space about nominal).
    first_failed_scale
        Smallest scale tried that failed (``inf`` when ``s_max`` certified).
    steps
        What was tried, in order: ``(scale, certified)``.
    parts
        :func:`_certify_box`'s answer at ``scale`` (family, LMI points, Lyapunov, grid family, grid check).
    dims
        Relevant coordinates of each subsystem on the certified box.
    """

    scale: float
    first_failed_scale: float
    steps: tuple[tuple[float, bool], ...]
    parts: tuple
    dims: Mapping[str, tuple[int, ...]]


def widest_box(vehicle, gains, inner, base: ParameterBox, *, tilt_limit_deg, rate_hz,
               grid_n: int = CASCADE_GRID_POINTS_PER_AXIS, widest: bool = False,
               steps: int = CASCADE_WIDEST_STEPS, s_max: float = CASCADE_WIDEST_SCALE_MAX,
               s_min: float = CASCADE_SMALLEST_SCALE) -> BoxSearch:
    """The widest scale ``s`` with ``base.scaled(s)`` certified, with the certificate's own grid check.

    Certified means what the certificate states: every subsystem LMI feasible at
    its LMI points (relevant coordinates of the scaled box) and the numpy grid
    check with ``grid_n`` points per coordinate passing.  The scale starts at 1
    and is halved until it certifies (down to ``s_min``).  With ``widest``, a
    certified 1 is followed by ``s_max``, and ``steps`` bisection steps then
    narrow the gap between the widest certified and the narrowest failed scale.

    Parameters
    ----------
    vehicle, gains, inner
        The design.
    base
        The box scaled (the Monte Carlo default box).
    tilt_limit_deg, rate_hz
        Tilt limit [deg] and control rate [Hz].
    grid_n
        Points per coordinate of the grid check.
    widest
        Search above the first certified scale too.
    steps, s_max, s_min
        Bisection steps, largest and smallest scale tried.

    Returns
    -------
    BoxSearch

    Raises
    ------
    SolverError
        Not even ``base.scaled(s_min)`` certifies.
    """
    tried: list[tuple[float, bool]] = []
    found: dict[float, tuple] = {}

    def ok(s: float) -> bool:
        box = base.scaled(s)
        try:
            dims = relevant_coordinates(vehicle, gains, inner, box, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz)
            found[s] = (_certify_box(vehicle, gains, inner, box, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                                     dims=dims, grid_n=grid_n), dims)
        except (SolverError, CascadeError):
            pass
        tried.append((s, s in found))
        return s in found

    s, bad = 1.0, math.inf
    while not ok(s):
        bad = s
        if s <= s_min:
            raise SolverError(f"the cascade is not certified even on the Monte Carlo box scaled by {s_min:g} "
                              f"(log space about the nominal point)")
        s = max(s / 2, s_min)
    if widest:
        if bad == math.inf and s_max > s:
            if ok(s_max):
                s = s_max
            else:
                bad = s_max
        for _ in range(steps if math.isfinite(bad) else 0):
            mid = 0.5 * (s + bad)
            s, bad = (mid, bad) if ok(mid) else (s, mid)
    parts, dims = found[s]
    return BoxSearch(scale=s, first_failed_scale=bad, steps=tuple(tried), parts=parts, dims=dims)


def _roa_axes(fam: CascadeFamily, box: ParameterBox, dims: Mapping[str, Sequence[int]]):
    out = {}
    for a in ("x", "y"):
        A_d, _, B, K = _subsystem(fam, a)
        out[a] = (A_d, B, K, _coords(box, fam.points, dims[a]))
    return out


def _vertex_margins(fam: CascadeFamily, rate_hz: float) -> dict[str, Any]:
    """Worst fast margins (:mod:`nniquad.analysis.fast_margins`) over the points of ``fam``."""
    from nniquad.analysis.fast_margins import fast_cascade_margins

    worst: dict[str, dict[str, Any]] = {}
    better = {"gm_db": lambda a, b: a < b, "gm_lower_db": lambda a, b: a > b, "pm_deg": lambda a, b: a < b}
    for i in range(len(fam)):
        pt = dict(zip(POINT_NAMES, (float(v) for v in fam.points[i])))
        for bp, m in fast_cascade_margins(fam.cascade_at(i), rate_hz).items():
            w = worst.setdefault(bp, {"stable": True})
            w["stable"] = bool(w["stable"] and m.stable)
            for k, cmp in better.items():
                v = getattr(m, k)
                if k not in w or cmp(v, w[k]):
                    w[k], w[k + "_point"] = v, pt
    for w in worst.values():
        for k, v in list(w.items()):
            if isinstance(v, float) and not math.isfinite(v):
                w[k] = str(v)
    return {"points": _MARGIN_POINTS, "model": _MARGIN_MODEL, "worst": worst}


def linear_zone_reach(lyap: Mapping[str, RobustLyapunov], dims, box: ParameterBox, fam: CascadeFamily,
                      L: float) -> float:
    """Smallest reach [m] over the points of ``fam`` of the linear-zone ellipsoid of the horizontal ``P(θ)``.

    At each point, with ``P = diag(P_x, P_y)``: the level ``c`` with
    ``sup_{xᵀPx <= c} ‖K x‖ = L`` is ``c = L² / max_a(K W_a Kᵀ)`` (``W_a = P_a⁻¹``);
    inside, the saturation is inactive and ``P`` contracts, so the set is invariant;
    a start ``r (cos α, sin α)`` has level ``r² (cos²α P_x00 + sin²α P_y00)``, so
    ``r = sqrt(c / max_a P_a00)``.
    """
    kmax, pmax = None, None
    for a in ("x", "y"):
        _, _, _, K = _subsystem(fam, a)
        P = _affine(lyap[a].P, _coords(box, fam.points, dims[a]))
        W = np.linalg.inv(P)
        kw = (K @ W @ K.T)[..., 0, 0]
        kmax = kw if kmax is None else np.maximum(kmax, kw)
        pmax = P[:, 0, 0] if pmax is None else np.maximum(pmax, P[:, 0, 0])
    return float(np.min(np.sqrt(L * L / kmax / pmax)))


def _solve_roa(vehicle, gains, inner, box, dims, L, rho_roa, tilt_limit_deg, rate_hz):
    """The ROA LMIs at the vertices of each axis's coordinates, or (if that fails) at a grid of 3 per coordinate."""
    err: Exception | None = None
    for n in (2, 3):
        vpts = {a: _subgrid(box, dims[a], n) for a in ("x", "y")}
        vfam = sampled_family(vehicle, gains, inner, np.vstack([vpts["x"], vpts["y"]]),
                              tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz)
        nx = vpts["x"].shape[0]
        ax_v = {"x": _roa_axes(_take(vfam, np.arange(nx)), box, dims)["x"],
                "y": _roa_axes(_take(vfam, np.arange(nx, len(vfam))), box, dims)["y"]}
        try:
            return robust_region_of_attraction(ax_v, L, rho_roa), ax_v, n
        except SolverError as exc:
            err = exc
    assert err is not None
    raise err


#: Sections already computed in this process, by their exact inputs (a section is a pure function of them).
_SECTIONS: dict[tuple, dict[str, Any]] = {}


def cascade_section(vehicle: Vehicle, gains: Gains, inner: InnerLoopGains, *, tilt_limit_deg: float,
                    rate_hz: float = CONTROL_RATE_HZ, box: ParameterBox | None = None,
                    widest: bool = False, roa_method: str = "linear_zone",
                    grid_points_per_axis: int = CASCADE_GRID_POINTS_PER_AXIS) -> dict[str, Any]:
    """The schema-2 ``cascade`` section of a certificate (module docstring for the maths).

    A section is a pure function of its inputs, so one computed earlier in the
    same process for the same inputs is returned again (a deep copy): the
    solves take about 15-40 s, and a test session builds the same design several times.
    """
    import copy

    key = (vehicle, gains, inner, float(tilt_limit_deg), float(rate_hz), box, bool(widest), roa_method,
           int(grid_points_per_axis))
    if key not in _SECTIONS:
        _SECTIONS[key] = _cascade_section(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                                          box=box, widest=widest, roa_method=roa_method,
                                          grid_points_per_axis=grid_points_per_axis)
    return copy.deepcopy(_SECTIONS[key])


def _cascade_section(vehicle: Vehicle, gains: Gains, inner: InnerLoopGains, *, tilt_limit_deg: float,
                     rate_hz: float = CONTROL_RATE_HZ, box: ParameterBox | None = None,
                     widest: bool = False, roa_method: str = "linear_zone",
                     grid_points_per_axis: int = CASCADE_GRID_POINTS_PER_AXIS) -> dict[str, Any]:
    """:func:`cascade_section` without the cache.

    Parameters
    ----------
    vehicle, gains, inner
        The design.
    tilt_limit_deg
        Tilt limit [deg] of the region of attraction.
    rate_hz
        Control rate [Hz].
    box
        The box to certify; ``None``: the Monte Carlo default box if it
        certifies, else its scale halved until it does (:func:`widest_box`).
    widest
        Search the widest scale of the Monte Carlo default box, up to
        :data:`~nniquad.config.CASCADE_WIDEST_SCALE_MAX` (a few more solves of
        the whole box: off by default to keep ``certify`` within its budget).
        With ``box=None`` the widest box is certified; with a given ``box`` it is
        only reported.
    grid_points_per_axis
        Points per coordinate of the numpy grid check (default
        :data:`nniquad.config.CASCADE_GRID_POINTS_PER_AXIS`).
    roa_method
        ``"linear_zone"`` (default) or ``"gsc"`` (also solve the generalised-sector LMI, about 30 s, and use it
        when it passes the numpy re-check on the whole grid and reaches further).

    Raises
    ------
    SolverError
        The box (or, with ``box=None``, even the nominal point) is not certified.
    """
    t0 = time.perf_counter()
    mc = ParameterBox.monte_carlo_default()
    grid_n = int(grid_points_per_axis)
    if grid_n < 2:
        raise CascadeError(f"the grid check needs at least 2 points per coordinate, got {grid_points_per_axis!r}")
    timings: dict[str, float] = {}
    search = None
    if box is None or widest:
        # one search, with the certificate's own grid: the Monte Carlo box, halved until it certifies
        search = widest_box(vehicle, gains, inner, mc, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                            grid_n=grid_n, widest=widest)
    if box is None:
        box = mc.scaled(search.scale) if search.scale != 1.0 else mc
        (fam, pts, lyap, grid_fam, gc), dims = search.parts, search.dims
    else:
        dims = relevant_coordinates(vehicle, gains, inner, box, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz)
        fam, pts, lyap, grid_fam, gc = _certify_box(vehicle, gains, inner, box, tilt_limit_deg=tilt_limit_deg,
                                                    rate_hz=rate_hz, dims=dims, grid_n=grid_n)
    s_ok = search.scale if search is not None else math.nan
    s_bad = search.first_failed_scale if search is not None else math.nan
    T = fam.T
    decay = min(l.decay_rate_1_s for l in lyap.values())
    # region of attraction: LMIs at the vertices of each axis's coordinates, re-checked on the LMI points and the grid
    L = tilt_accel_limit(vehicle, box, tilt_limit_deg)
    rho_roa = math.exp(-CASCADE_ROA_DECAY_FRACTION * min(lyap["x"].decay_rate_1_s, lyap["y"].decay_rate_1_s) * T)
    timings["box_lyapunov_and_grid_s"] = time.perf_counter() - t0  # the box search included
    # the GSC ellipsoid (roa_method="gsc") is certified at its LMI points; it is used only if the numpy re-check
    # passes on the whole grid too, else the linear-zone ellipsoid of P(θ) (always grid-verified) is used
    lz_lmi = linear_zone_reach(lyap, dims, box, fam, L)
    lz_grid = linear_zone_reach(lyap, dims, box, grid_fam, L)
    roa_block: dict[str, Any] = {"u0_m_s2": L, "tilt_limit_deg": float(tilt_limit_deg)}
    method = "linear_zone"
    if roa_method == "gsc":
        roa, ax_v, n_roa = _solve_roa(vehicle, gains, inner, box, dims, L, rho_roa, tilt_limit_deg, rate_hz)
        ax_g = _roa_axes(grid_fam, box, dims)
        added = 0
        for _ in range(GSC_CUTTING_ROUNDS):
            # cutting planes: the grid points where the decrease fails join the LMI points, and it is solved again
            dec = {a: _roa_decrease(roa, {a: ax_g[a]})[a] for a in ("x", "y")}
            bad = {a: np.argsort(-d)[:GSC_CUTTING_POINTS][np.sort(-d)[:GSC_CUTTING_POINTS] <= 0] for a, d in dec.items()}
            if not any(len(v) for v in bad.values()):
                break
            ax_v = {a: tuple(np.concatenate([ax_v[a][i], ax_g[a][i][bad[a]]]) if i != 2 else ax_v[a][i]
                             for i in range(4)) for a in ("x", "y")}
            added += sum(len(v) for v in bad.values())
            roa = robust_region_of_attraction(ax_v, L, rho_roa)
        reach = roa.reach_m * (1.0 - 1e-6)
        rc_grid = roa_recheck(roa, ax_g, reach)
        rc_v = roa_recheck(roa, ax_v, reach)
        gsc_ok = all(r["decrease_max_eig"] < 0 and r["inclusion_margin"] >= 0 and r["min_eig_W"] > 0
                     and r["start_level"] <= 1 for r in (rc_grid, rc_v))
        roa_block["gsc"] = {"max_displacement_m": reach, "rho": rho_roa, "S": roa.S,
                            "W": {a: roa.Wk[a].tolist() for a in ("x", "y")},
                            "Z": {a: roa.Zk[a].tolist() for a in ("x", "y")}, "lmi_points_per_axis": n_roa,
                            "recheck_lmi_points": rc_v, "recheck_grid": rc_grid, "ok": gsc_ok,
                            "grid_points_added": added}
        if gsc_ok and reach > min(lz_lmi, lz_grid):
            method = "gsc"
    roa_block.update({
        "method": method,
        "max_displacement_m": roa_block["gsc"]["max_displacement_m"] if method == "gsc" else min(lz_lmi, lz_grid),
        "linear_zone_reach_lmi_points_m": lz_lmi, "linear_zone_reach_grid_m": lz_grid,
        "note": _ROA_NOTE,
    })
    timings["roa_s"] = time.perf_counter() - t0 - sum(timings.values())
    mdims = tuple(sorted(set(dims["x"]) | set(dims["y"])))
    margins = _vertex_margins(sampled_family(vehicle, gains, inner, _subgrid(box, mdims, 2),
                                             tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz), rate_hz)
    nom = _take(fam, np.arange(1))
    loops = _block_loops(fam, box, pts, dims)
    timings["margins_s"] = time.perf_counter() - t0 - sum(timings.values())
    section = {
        "rate_hz": float(rate_hz), "controller": "discrete", "attitude_loop": "continuous", "model": _MODEL,
        "box": box.to_json(), "monte_carlo_default_box": mc.to_json(),
        "covers_monte_carlo_default": bool(box.contains(mc)),
        # how the box was found: a record (nniquad.certificates.verify.RECORD_FIELDS), not a claim: verify
        # re-checks the certified box, and does not re-run the search
        "box_search": None if search is None else {
            "base": "monte_carlo_default_box", "scaling": "log space about nominal: [lo^s, hi^s]",
            "method": "bisection" if widest else "halving", "grid_points_per_axis": grid_n,
            "widest_certified_scale": s_ok,
            "first_failed_scale": str(s_bad) if not math.isfinite(s_bad) else s_bad,
            "scales_tried": [{"scale": sc, "certified": ok} for sc, ok in search.steps]},
        "lyapunov": {
            "form": _FORM, "coverage": _COVERAGE,
            "period_s": T, "rho": max(l.rho for l in lyap.values()), "coupling": coupling(nom),
            "subsystems": {name: {"states": list(SUBSYSTEMS[name]), "dims": [POINT_NAMES[j] for j in dims[name]],
                                  "lmi_points": int(pts[name].shape[0]), "rho": l.rho,
                                  "decay_rate_1_s": l.decay_rate_1_s, "spectral_radius": l.spectral_radius,
                                  **_margin_fields(witness_margins(l.P, *loops[name])),
                                  "P": l.P.tolist()} for name, l in lyap.items()},
        },
        "grid": gc.to_json(),
        "region_of_attraction": roa_block,
        "margins": margins,
        "matrices": {"state_names": list(fam.state_names), "A_d": nom.A_d[0].tolist(), "Phi": nom.Phi[0].tolist(),
                     "Gamma_d": nom.Gam[0].tolist(), "A_kd": fam.A_kd.tolist(), "B_kd": fam.B_kd.tolist(),
                     "C_k": fam.C_k.tolist(), "D_k": fam.D_k.tolist()},
        "decay_rate_1_s": decay,
    }
    last_timings.clear()
    last_timings.update(timings, total_s=time.perf_counter() - t0)
    return section


# =============================================================================== the check


def _margin_fields(wm: WitnessMargins) -> dict[str, float]:
    """A subsystem's stated rounding margins: ``1 - rho`` must exceed ``rho_rounding_bound``, and the smallest
    eigenvalue of the scaled ``P(θ)`` at the cube's corners must exceed ``min_eig_bound``."""
    return {"rho_rounding_bound": wm.rho_bound, "min_eig_scaled": wm.definite, "min_eig_bound": wm.definite_bound}



def _close(a: Any, b: Any, rtol: float = 1e-9) -> bool:
    try:
        A, B = np.asarray(a, float), np.asarray(b, float)
    except (TypeError, ValueError):
        return False
    if A.shape != B.shape:
        return False
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        return bool(np.array_equal(A, B))
    return bool(np.all(np.abs(A - B) <= rtol * np.maximum(np.abs(B), 1.0) + 1e-300)) if A.size else True


def _num(v: Any) -> float:
    return float(v) if not isinstance(v, str) else float(v)


def _same_worst(stated: Mapping[str, Any], gc: GridCheck, points: np.ndarray) -> bool:
    """The stated worst values equal the recomputed ones, and each stated worst point is a grid point whose own
    value equals the recomputed worst, all within the rounding bound (never *which* of tied points is stated:
    many grid points tie to rounding, and another machine's argmax may pick another of them)."""
    tol = max(1e-9, gc.rounding_bound)
    for value_key, point_key, values in (("worst_rho", "worst_point", gc.rho_all),
                                         ("worst_spectral_radius", "worst_spectral_point", gc.spectral_all)):
        worst = float(np.max(values))
        i = point_index(points, [stated[point_key][n] for n in POINT_NAMES])
        if not (_is_number(stated.get(value_key)) and abs(float(stated[value_key]) - worst) <= tol
                and i is not None and abs(float(values[i]) - worst) <= tol):
            return False
    return _is_number(stated.get("worst_margin")) and abs(float(stated["worst_margin"]) - (1.0 - gc.worst_rho)) <= tol


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


#: Families rebuilt by :func:`check_cascade_section` in this process, by their exact inputs: the rebuild is
#: a pure function of the design, the rate and the points, and a tampering loop re-checks one design hundreds
#: of times (every stated number is still compared afresh against it).
_FAMILIES: dict[tuple, "CascadeFamily"] = {}


def _family_cached(vehicle: Vehicle, gains: Gains, inner: InnerLoopGains, points: np.ndarray, tilt_limit_deg: float,
                   rate_hz: float) -> "CascadeFamily":
    pts = np.ascontiguousarray(points, dtype=float)
    key = (vehicle, gains, inner, float(tilt_limit_deg), float(rate_hz), pts.shape, pts.tobytes())
    if key not in _FAMILIES:
        if len(_FAMILIES) >= 16:
            _FAMILIES.clear()
        _FAMILIES[key] = sampled_family(vehicle, gains, inner, pts, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz)
    return _FAMILIES[key]


def check_cascade_section(section: Mapping[str, Any], vehicle: Vehicle, gains: Gains, inner: InnerLoopGains, *,
                          tilt_limit_deg: float) -> list[tuple[str, bool, str]]:
    """Re-check a ``cascade`` section from the design alone (cheap checks first).

    Every system matrix is rebuilt from ``vehicle``, ``gains``, ``inner``, the
    stated rate and the stated box (no stored ``A`` is trusted); the stored
    nominal matrices are compared with the rebuilt ones; every Lyapunov
    condition is re-checked with numpy at the LMI points (contraction of
    ``P(θ)`` equal to the stated ``ρ < 1``, ``P(θ) ≻ 0`` on the cube's corners);
    the grid check is re-run and every stated number compared (relative 1e-9);
    the reach is recomputed; the margins are recomputed at the stated worst
    vertices.  The box search (``box_search``) is a record, not re-run: the
    certified box is what is checked.

    Returns
    -------
    list of (name, ok, detail)
    """
    out: list[tuple[str, bool, str]] = []

    def add(name: str, ok: bool, detail: str = "") -> bool:
        out.append((name, bool(ok), detail))
        return bool(ok)

    need = ("rate_hz", "controller", "attitude_loop", "model", "box", "monte_carlo_default_box",
            "covers_monte_carlo_default", "lyapunov", "grid", "region_of_attraction", "margins", "matrices",
            "decay_rate_1_s")
    missing = [k for k in need if not isinstance(section, Mapping) or k not in section]
    if not add("section keys", not missing, f"missing {missing}" if missing else "all present"):
        return out
    try:
        rate = float(section["rate_hz"])
        T = _period(rate)
        box = ParameterBox.from_json(section["box"])
        mc = ParameterBox.from_json(section["monte_carlo_default_box"])
    except (CascadeError, TypeError, ValueError) as exc:
        add("rate and box", False, str(exc))
        return out
    add("controller variant", section["controller"] == "discrete" and section["attitude_loop"] == "continuous"
        and section["model"] == _MODEL, f"{section['controller']}, attitude {section['attitude_loop']}")
    add("Monte Carlo default box", mc == ParameterBox.monte_carlo_default(), str(mc.to_json()))
    try:
        texts = (section["lyapunov"]["form"] == _FORM and section["lyapunov"]["coverage"] == _COVERAGE
                 and section["region_of_attraction"]["note"] == _ROA_NOTE
                 and section["margins"]["points"] == _MARGIN_POINTS and section["margins"]["model"] == _MARGIN_MODEL
                 and all(list(section["lyapunov"]["subsystems"][n]["states"]) == list(SUBSYSTEMS[n])
                         for n in SUBSYSTEMS))
    except (KeyError, TypeError):
        texts = False
    add("stated method texts and subsystem states", texts, "form, coverage, notes, states")
    add("covers_monte_carlo_default", section["covers_monte_carlo_default"] is box.contains(mc),
        f"stated {section['covers_monte_carlo_default']}, box contains it: {box.contains(mc)}")
    roa = section["region_of_attraction"]
    L = tilt_accel_limit(vehicle, box, tilt_limit_deg)
    add("tilt limit and u0", _close(roa.get("tilt_limit_deg"), tilt_limit_deg) and _close(roa.get("u0_m_s2"), L),
        f"u0 = {L:.6g} m/s^2 at {tilt_limit_deg:g} deg")
    lyap_s = section["lyapunov"]
    try:
        subs = lyap_s["subsystems"]
        dims = {name: tuple(POINT_NAMES.index(d) for d in subs[name]["dims"]) for name in SUBSYSTEMS}
        Pk = {name: np.asarray(subs[name]["P"], float) for name in SUBSYSTEMS}
        rhos = {name: float(subs[name]["rho"]) for name in SUBSYSTEMS}
    except (KeyError, TypeError, ValueError) as exc:
        add("lyapunov block", False, f"unreadable ({exc})")
        return out
    # ---- rebuild every matrix in one batched call: nominal, relevance probes, LMI points, grid
    grid_n = int(section["grid"].get("points_per_axis", CASCADE_GRID_POINTS_PER_AXIS))
    probes = _relevance_points(box)
    pts = {name: _subgrid(box, dims[name], LMI_POINTS_PER_AXIS) for name in SUBSYSTEMS}
    allp = np.vstack([np.ones((1, 6))] + list(pts.values()) + [box.grid(grid_n), probes])
    try:
        big = _family_cached(vehicle, gains, inner, allp, tilt_limit_deg, rate)
    except CascadeError as exc:
        add("rebuild", False, str(exc))
        return out
    n_cert = 1 + sum(p.shape[0] for p in pts.values()) + box.grid(grid_n).shape[0]
    big.spectral_radius  # noqa: B018  once per rebuilt family (it is cached): every check below shares it
    fam = _take(big, np.arange(n_cert))
    add("relevant coordinates", relevance_consistent(_take(big, np.arange(n_cert, len(big))), box, dims),
        str({k: subs[k]["dims"] for k in SUBSYSTEMS}))
    mats = section["matrices"]
    nom = _take(fam, np.arange(1))
    ok = (list(mats.get("state_names", [])) == list(fam.state_names) and _close(mats.get("A_d"), nom.A_d[0])
          and _close(mats.get("Phi"), nom.Phi[0]) and _close(mats.get("Gamma_d"), nom.Gam[0])
          and _close(mats.get("A_kd"), fam.A_kd) and _close(mats.get("B_kd"), fam.B_kd)
          and _close(mats.get("C_k"), fam.C_k) and _close(mats.get("D_k"), fam.D_k))
    add("nominal matrices rebuilt", ok, "A_d, Phi, Gamma_d, A_kd, B_kd, C_k, D_k vs the design")
    cpl = coupling(nom)
    add("subsystems decoupled", cpl <= COUPLING_TOL and _close(lyap_s.get("coupling"), cpl, 1e-6),
        f"coupling {cpl:.3g} (stated {lyap_s.get('coupling')})")
    lyap: dict[str, RobustLyapunov] = {}
    loops = _block_loops(fam, box, pts, dims)
    k = 1 + sum(p.shape[0] for p in pts.values())
    for name in SUBSYSTEMS:
        A, th = loops[name]
        m, q = A.shape[0], th.shape[1]
        good = Pk[name].shape == (q + 1, len(SUBSYSTEMS[name]), len(SUBSYSTEMS[name]))
        detail = "bad P shape"
        if good:
            wm = witness_margins(Pk[name], A, th)
            sr = float(np.max(np.abs(np.linalg.eigvals(A))))
            rho = rhos[name]
            # the stated rho is the numpy contraction of the stated P at the LMI points (best_decay,
            # reach_lyapunov), equal within its rounding bound: another witness P, even a valid one, is not the
            # one signed; rho < 1 and P > 0 each hold with a margin above rounding (WitnessMargins.ok)
            tol = max(1e-9, wm.rho_bound) if math.isfinite(wm.rho_bound) else 1e-9
            stated_margins = {key: subs[name].get(key) for key in _margin_fields(wm)}
            good = (wm.ok and abs(wm.rho - rho) <= tol and m == subs[name]["lmi_points"]
                    and _close(subs[name]["spectral_radius"], sr)
                    and _close(subs[name]["decay_rate_1_s"], -math.log(rho) / T)
                    and all(_close(stated_margins[key], v, 1e-6) for key, v in _margin_fields(wm).items()))
            detail = (f"{m} points, contraction {wm.rho:.10f} = rho {rho:.10f} < 1 by {1 - wm.rho:.3g} "
                      f"(rounding bound {wm.rho_bound:.2g}); min eig scaled P {wm.definite:.3g} "
                      f"(bound {wm.definite_bound:.2g})")
            lyap[name] = RobustLyapunov(P=Pk[name], rho=rho, rho_vertices=wm.rho_all, spectral_radius=sr, T=T,
                                        decay_rate_1_s=-math.log(rho) / T, min_eig_P=wm.min_eig_ratio,
                                        status="stored", ok=good)
        add(f"Lyapunov LMI [{name}]", good, detail)
    if len(lyap) != len(SUBSYSTEMS):
        return out
    add("rho and decay rate", _close(lyap_s.get("rho"), max(rhos.values())) and _close(lyap_s.get("period_s"), T)
        and _close(section["decay_rate_1_s"], min(l.decay_rate_1_s for l in lyap.values())),
        f"decay {min(l.decay_rate_1_s for l in lyap.values()):.6g} 1/s")
    grid_fam = _take(fam, np.arange(k, n_cert))
    try:
        gc = grid_check(grid_fam, _assemble_P(lyap, dims, box, grid_fam.points, fam.state_names), grid_n)
        g = section["grid"]
        ok = (gc.ok and g.get("size") == gc.size and g.get("ok") is True
              and _same_worst(g, gc, grid_fam.points)
              and _close(g.get("rounding_bound"), gc.rounding_bound, 1e-6)
              and _close(g.get("margin_over_bound"), gc.margin_over_bound, 1e-6))
        add("grid check", ok, f"{gc.size} points, worst rho {gc.worst_rho:.8f} (1 - rho >= {gc.margin_over_bound:.3g} "
                              f"x its rounding bound, <= {gc.rounding_bound:.2g}), worst spectral radius "
                              f"{gc.worst_spectral_radius:.8f}")
    except (KeyError, TypeError, ValueError, np.linalg.LinAlgError) as exc:
        add("grid check", False, f"unreadable or not positive definite ({exc})")
    try:
        lz_lmi = linear_zone_reach(lyap, dims, box, fam, L)
        lz_grid = linear_zone_reach(lyap, dims, box, grid_fam, L)
        method = roa.get("method")
        ok = _close(roa.get("linear_zone_reach_lmi_points_m"), lz_lmi) and _close(roa.get("linear_zone_reach_grid_m"),
                                                                                  lz_grid)
        if method == "linear_zone":
            ok = ok and _close(roa.get("max_displacement_m"), min(lz_lmi, lz_grid))
        elif method == "gsc":
            gs = roa["gsc"]
            rr = RobustROA(Wk={a: np.asarray(gs["W"][a], float) for a in ("x", "y")},
                           Zk={a: np.asarray(gs["Z"][a], float) for a in ("x", "y")}, S=float(gs["S"]),
                           rho=float(gs["rho"]), L=L, reach_m=float(roa["max_displacement_m"]), dims=dims,
                           status="stored")
            r1 = roa_recheck(rr, _roa_axes(grid_fam, box, dims))
            ok = ok and r1["decrease_max_eig"] < 0 and r1["inclusion_margin"] >= 0 and r1["start_level"] <= 1 \
                and _close(gs["max_displacement_m"], roa["max_displacement_m"])
        else:
            ok = False
        if "gsc" in roa:  # the generalised-sector answer, adopted or not: its re-check numbers are recomputed
            gs = roa["gsc"]
            rr = RobustROA(Wk={a: np.asarray(gs["W"][a], float) for a in ("x", "y")},
                           Zk={a: np.asarray(gs["Z"][a], float) for a in ("x", "y")}, S=float(gs["S"]),
                           rho=float(gs["rho"]), L=L, reach_m=float(gs["max_displacement_m"]), dims=dims,
                           status="stored")
            r1 = roa_recheck(rr, _roa_axes(grid_fam, box, dims), float(gs["max_displacement_m"]))
            ok = ok and all(_close(gs["recheck_grid"][key], r1[key], 1e-6) for key in r1) and gs["ok"] is (
                r1["decrease_max_eig"] < 0 and r1["inclusion_margin"] >= 0 and r1["min_eig_W"] > 0
                and r1["start_level"] <= 1 and gs["recheck_lmi_points"]["decrease_max_eig"] < 0)
        add("region of attraction", ok, f"{method}: reach {roa.get('max_displacement_m')} m")
    except (KeyError, TypeError, ValueError, np.linalg.LinAlgError) as exc:
        add("region of attraction", False, f"unreadable ({exc})")
    # ---- margins at the stated worst points (the most expensive check: last)
    try:
        from nniquad.analysis.fast_margins import fast_cascade_margins

        worst = section["margins"]["worst"]
        wpts = []
        for bp, w in worst.items():
            for key in ("gm_db", "gm_lower_db", "pm_deg"):
                wpts.append((bp, key, w[key], [float(w[key + "_point"][n]) for n in POINT_NAMES]))
        uniq = sorted({tuple(p[3]) for p in wpts})
        mf = _family_cached(vehicle, gains, inner, np.array(uniq, float), tilt_limit_deg, rate)
        got = {u: fast_cascade_margins(mf.cascade_at(i), rate) for i, u in enumerate(uniq)}
        mdims = set(dims["x"]) | set(dims["y"])
        lo, hi = box.bounds()
        ok = all(_close(_num(v), getattr(got[tuple(p)][bp], key), 1e-6) for bp, key, v, p in wpts) and all(
            w["stable"] is True for w in worst.values()) and all(got[tuple(p)][bp].stable for bp, _, _, p in wpts) and all(
            all((p[j] == lo[j] or p[j] == hi[j]) if j in mdims else p[j] == 1.0 for j in range(6)) for *_, p in wpts)
        add("margins at the stated worst vertices", ok, f"{len(uniq)} vertices recomputed")
    except (KeyError, TypeError, ValueError, CascadeError) as exc:
        add("margins at the stated worst vertices", False, f"unreadable ({exc})")
    return out
