"""The linearised cascade at hover, derived from the simulator's symbolic closed loop.

What is linearised
------------------
The closed-loop right-hand side :func:`nniquad.sim.rhs_function` of the
simulator (itself generated from the sympy model of :mod:`nniquad.model.symbolic`
and the inner loops of :mod:`nniquad.control.inner_loops`) is differentiated
with CasADi at hover.  Nothing is retyped: every matrix below is a block of
those Jacobians.  The cascade holds

* the horizontal NNI law ``a_h = -k_p ξ_m + z/m̂``, ``z' = -Γδ z + Γ ξ_m`` (both axes);
* the attitude PD with gyro damping in its linear region (the square-root
  shaping is exactly linear for ``|e| <= α/k²``, so its slope at zero is ``k``);
* the allocation and the first-order motor lag ``ω' = (ω_cmd - ω)/τ_m``;
* the altitude PID (it decouples from the horizontal loops at first order at
  hover, but it is kept in the state because it is part of the cascade);
* the yaw hold.

The Jacobians are taken with the simulator's ``sample_hold`` switch **on**:
then the controller reads the held states ``held_x, held_y`` instead of the
position, and the Jacobian with respect to them is the measurement input.  This
splits the loop, without any modelling by hand, into

* the **plant** ``p' = A_p p + B_p a_h``, ``ξ = C_p p`` (vehicle, attitude loop,
  allocation, motors, altitude and yaw loops), input the horizontal
  acceleration command ``a_h`` [m/s²], output the position [m];
* the **controller** ``z' = A_k z + B_k ξ_m``, ``a_h = C_k z + D_k ξ_m``.

:func:`linearise_cascade` checks that this split is exact (the plant sees the
controller only through ``a_h``; the law reads no state but the measurement
and its own: it is velocity-free) and raises :class:`CascadeError` otherwise.
The motor block is split once more: ``ω_cmd = W_r r + W_a a_h`` (``r`` the
rigid-body and altitude-integrator states) and the allocation Jacobian ``M``
(``δω_cmd = M δ(u1, τ_φ, τ_θ, τ_ψ)``, from :func:`nniquad.control.inner_loops.allocate`)
exposes the roll-torque command for the attitude-loop break point.  Without
motor lag the rotors follow ``ω_cmd`` instantly, so that plant is built from
the same blocks (``A_rr + A_rw W_r``); the tests compare it with the Jacobian
of the simulator run with the motor lag off.

Why a symmetric offset
----------------------
At exact hover ``a_h = 0`` and the tilt limit ``a · L/max(‖a‖, L)`` has a
``0 · ∂‖a‖/∂a`` term, which automatic differentiation evaluates as ``0 · NaN``.
The function itself is linear there (the limit is inactive), so the Jacobian is
taken as the mean of the Jacobians at ``±ε`` along the held measurement
(``ε`` = :data:`LINEARISATION_OFFSET_M`): the odd terms cancel and the error is
``O(ε²)`` (``~1e-12`` relative), far below every tolerance used here.

Sampling
--------
The position measurement is sampled at ``f_s`` and held.  :meth:`LinearCascade.closed_loop`
models the sampling in continuous time by Padé approximants (order
``pade_order``) of the delays a sample-and-hold adds at low frequency: ``T/2``
on the measurement, and for the NNI controller run in discrete time (its exact
ZOH equivalent, :mod:`nniquad.analysis.sampled`) another ``T/2`` on the path
through the controller state (the ZOH equivalent of ``C(s)`` behaves as
``C(s) e^{-sT/2}``).  The exact discrete-time treatment is in
:mod:`nniquad.analysis.sampled`; the tests compare both.  The closed loop with
its break points (:class:`ClosedLoop`) and the Padé realisation are plain
matrix algebra, in :mod:`nniquad.analysis.loops`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import casadi as ca
import numpy as np

from nniquad.analysis.hover_jacobian import EQUILIBRIUM_TOL, LINEARISATION_OFFSET_M, Linearisation, linearise
from nniquad.analysis.loops import ClosedLoop, pade_delay
from nniquad.config import TILT_LIMIT_DEG
from nniquad.control import inner_loops as IL
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.errors import CascadeError
from nniquad.laws.base import GainBlock
from nniquad.model.layout import PARAM_NAMES
from nniquad.model.vehicle import Vehicle
from nniquad.sim import SimOptions, SimParams

__all__ = [
    "LINEARISATION_OFFSET_M",
    "EQUILIBRIUM_TOL",
    "SPLIT_TOL",
    "BREAK_POINTS",
    "CONTROLLER_VARIANTS",
    "Linearisation",
    "LinearCascade",
    "CascadeSplit",
    "split_cascade",
    "ClosedLoop",
    "linearise",
    "linearise_cascade",
]

#: Largest relative residual of the plant/controller split before it is declared inexact.
SPLIT_TOL = 1e-9
#: Break points of the loop transfer functions: the horizontal command a_h (x axis) and the roll torque.
BREAK_POINTS: tuple[str, ...] = ("horizontal", "attitude")
#: How the NNI controller meets the sampled measurement: "discrete" (its exact ZOH equivalent,
#: output held; what the export runs) or "held" (the continuous controller fed by the held
#: measurement; what the simulator's ``sample_hold`` does today).
CONTROLLER_VARIANTS: tuple[str, ...] = ("discrete", "held")


# =============================================================================== the split cascade


def _split_residual(M: np.ndarray, approx: np.ndarray) -> float:
    scale = max(float(np.max(np.abs(M))), 1.0)
    return float(np.max(np.abs(M - approx))) / scale if M.size else 0.0


@dataclass(frozen=True)
class CascadeSplit:
    """The simulator's Jacobians at hover split into plant, controller and motors, at one or many points (index 0
    of every stacked array is a point): what :func:`linearise_cascade` and the sampled family of the cascade
    certificate (:func:`nniquad.analysis.cascade.family.sampled_family`) both build on.

    Attributes
    ----------
    rigid : tuple of str
        The rigid body's states (with the altitude integrator).
    motors : tuple of str
        The rotor speeds.
    controller : tuple of str
        The law's controller states.
    held : tuple of str
        The held measurement.
    ir, iw, ik, ih : list of int
        Their positions in the simulator's state, in the same order.
    A_k, B_k, C_k, D_k : ndarray
        The controller (the same at every point: it is the flight code's), ``z' = A_k z + B_k ξ_m``,
        ``a_h = C_k z + D_k ξ_m``.
    A_p, B_p : ndarray
        The plant (rigid body, then rotors) at each point, ``(N, n_p, n_p)`` and ``(N, n_p, 2)``, input the
        acceleration command ``a_h``.
    """

    rigid: tuple[str, ...]
    motors: tuple[str, ...]
    controller: tuple[str, ...]
    held: tuple[str, ...]
    ir: list[int]
    iw: list[int]
    ik: list[int]
    ih: list[int]
    A_k: np.ndarray
    B_k: np.ndarray
    C_k: np.ndarray
    D_k: np.ndarray
    A_p: np.ndarray
    B_p: np.ndarray


def split_cascade(J: np.ndarray, Y: np.ndarray, names: Sequence[str], controller: Sequence[str]) -> CascadeSplit:
    """Split stacked Jacobians of the closed loop into plant, controller and motors, checking that the split is exact.

    Parameters
    ----------
    J : ndarray (N, n, n)
        ``∂f/∂x`` at each point.
    Y : ndarray (N, 2, n)
        ``∂a_h/∂x`` at each point.
    names
        The simulator's state names.
    controller
        The law's controller states (:attr:`nniquad.laws.base.ControlLaw.sim_state_names`).

    Raises
    ------
    CascadeError
        The law differs between points or reads a plant state, the plant sees the controller other than through
        ``a_h``, or ``a_h`` reaches the rigid body other than through the rotors.
    """
    held, motors = ("held_x", "held_y"), ("w1", "w2", "w3", "w4")
    ctrl = tuple(controller)
    rigid = tuple(n for n in names if n not in ctrl + held + motors)
    si = {n: i for i, n in enumerate(names)}
    ik, ih, iw, ir = ([si[n] for n in group] for group in (ctrl, held, motors, rigid))
    ip = ir + iw
    A_k, B_k = J[0][np.ix_(ik, ik)], J[0][np.ix_(ik, ih)]
    C_k, D_k = Y[0][:, ik], Y[0][:, ih]
    # the controller is the flight code's: the same at every point, and velocity-free (it reads no plant state)
    scale = max(1.0, float(np.max(np.abs(J[0]))))
    for M, name in ((J[:, ik][:, :, ik] - A_k, "A_k"), (J[:, ik][:, :, ih] - B_k, "B_k"),
                    (Y[:, :, ik] - C_k, "C_k"), (Y[:, :, ih] - D_k, "D_k"),
                    (J[:, ik][:, :, ip], "z' from plant"), (Y[:, :, ip], "a_h from plant")):
        if M.size and np.max(np.abs(M)) > SPLIT_TOL * scale:
            raise CascadeError(f"the horizontal law is not one velocity-free law at every point ({name}): the split "
                               "is not exact")
    # the plant sees the controller only through a_h: J[p, (z, held)] = B_p [C_k D_k]
    G = np.hstack([C_k, D_k])
    Jpc = J[:, ip][:, :, ik + ih]
    B_p = Jpc @ np.linalg.pinv(G)
    res = np.max(np.abs(Jpc - B_p @ G)) / max(1.0, float(np.max(np.abs(Jpc))))
    if res > SPLIT_TOL:
        raise CascadeError(f"the plant does not see the controller through a_h alone (relative {res:.3g})")
    if np.max(np.abs(B_p[:, : len(ir)])) > SPLIT_TOL * max(1.0, float(np.max(np.abs(B_p)))):
        raise CascadeError("a_h reaches the rigid body other than through the rotors")
    return CascadeSplit(rigid, motors, ctrl, held, ir, iw, ik, ih, A_k, B_k, C_k, D_k, J[:, ip][:, :, ip], B_p)


@dataclass(frozen=True)
class LinearCascade:
    """The linearised cascade at hover, split into plant, controller and motors.

    Built by :func:`linearise_cascade`; every array is a block of the
    simulator's Jacobians (module docstring).

    Attributes
    ----------
    vehicle, gains, inner
        What was linearised.
    motor_lag
        Whether the plant has the first-order motor lag.
    lin
        The raw :class:`Linearisation` of the ``full`` model (motor lag on).
    plant_states, rigid_states, controller_states
        Names of the plant states (rigid body, altitude integrator and, with
        motor lag, the four rotor speeds), of the rigid part and of the NNI
        controller states.
    A_p, B_p, C_p
        Plant: ``p' = A_p p + B_p a_h``, ``ξ = C_p p``; ``a_h`` [m/s²], ``ξ`` [m].
    A_k, B_k, C_k, D_k
        NNI controller: ``z' = A_k z + B_k ξ_m``, ``a_h = C_k z + D_k ξ_m``.
    W_r, W_a
        Rotor-speed command ``ω_cmd = W_r r + W_a a_h`` [rad/s] (``r`` the rigid states).
    A_rw
        Effect of the actual rotor speeds on the rigid states.
    tau_motor
        Motor time constant [s] of the linearisation.
    M_alloc : ndarray (4, 4)
        Allocation Jacobian ``∂ω_cmd/∂(u1, τ_φ, τ_θ, τ_ψ)`` at hover [rad/s per N, N m].
    """

    vehicle: Vehicle
    gains: GainBlock
    inner: InnerLoopGains
    motor_lag: bool
    lin: Linearisation
    plant_states: tuple[str, ...]
    rigid_states: tuple[str, ...]
    controller_states: tuple[str, ...]
    A_p: np.ndarray
    B_p: np.ndarray
    C_p: np.ndarray
    A_k: np.ndarray
    B_k: np.ndarray
    C_k: np.ndarray
    D_k: np.ndarray
    W_r: np.ndarray
    W_a: np.ndarray
    A_rw: np.ndarray
    tau_motor: float
    M_alloc: np.ndarray

    # ------------------------------------------------------------------ signals
    @property
    def n_plant(self) -> int:
        return self.A_p.shape[0]

    def torque_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """Roll-torque command ``τ_φ = t_r r + t_a a_h`` [N m] (row 1 of ``M⁻¹ ω_cmd``)."""
        Minv = np.linalg.inv(self.M_alloc)
        return Minv[1] @ self.W_r, Minv[1] @ self.W_a

    def torque_injection(self) -> np.ndarray:
        """Effect on the plant state derivative of a unit roll-torque command [per N m]."""
        col = self.M_alloc[:, 1]
        nr = len(self.rigid_states)
        if self.motor_lag:
            b = np.zeros(self.n_plant)
            b[nr:] = col / self.tau_motor
            return b
        return self.A_rw @ col

    def torque_plant_row(self) -> np.ndarray:
        """``t_r`` extended by zeros over the rotor states (a row over the plant states)."""
        t_r, _ = self.torque_rows()
        row = np.zeros(self.n_plant)
        row[: len(self.rigid_states)] = t_r
        return row

    # ------------------------------------------------------------------ closed loop
    def closed_loop(self, rate_hz: float | None = None, *, variant: str = "discrete",
                    pade_order: int = 2) -> ClosedLoop:
        """The continuous-time closed loop, optionally with Padé models of the sampling delays.

        Parameters
        ----------
        rate_hz
            Sample rate of the position measurement [Hz]; ``None`` for a
            continuous measurement.
        variant
            ``"discrete"`` (NNI controller run in discrete time, delays ``T/2``
            on the measurement and ``T/2`` more on the controller-state path) or
            ``"held"`` (continuous controller on the held measurement: ``T/2``).
        pade_order
            Order of each Padé approximant.

        Returns
        -------
        ClosedLoop
            States: the plant, the delay states, the controller; break points
            ``"horizontal"`` (``a_h`` x axis) and ``"attitude"`` (roll torque).
        """
        if variant not in CONTROLLER_VARIANTS:
            raise CascadeError(f"unknown controller variant {variant!r} (choose one of "
                               f"{', '.join(CONTROLLER_VARIANTS)})")
        n_p, n_k = self.n_plant, self.A_k.shape[0]
        n_y = self.C_p.shape[0]
        delays: list[tuple[np.ndarray, ...]] = []
        if rate_hz is not None:
            if not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
                raise CascadeError(f"sample rate must be a finite positive number of Hz, got {rate_hz!r}")
            T = 1.0 / float(rate_hz)
            d = pade_delay(T / 2, int(pade_order))
            # one Padé block per axis
            blk = tuple(np.kron(np.eye(n_y), M) for M in d)
            delays = [blk] if variant == "held" else [blk, blk]
        n_d = [D[0].shape[0] for D in delays]
        N = n_p + sum(n_d) + n_k
        off_k = n_p + sum(n_d)
        # signal rows (each a map from the closed-loop state): measurement chain
        xi = np.zeros((n_y, N))
        xi[:, :n_p] = self.C_p
        chain = [xi]
        A = np.zeros((N, N))
        off = n_p
        for (Ad, Bd, Cd, Dd), nd in zip(delays, n_d):
            prev = chain[-1]
            A[off:off + nd, off:off + nd] += Ad
            A[off:off + nd] += Bd @ prev
            out = Dd @ prev
            out[:, off:off + nd] += Cd
            chain.append(out)
            off += nd
        xi_p = chain[1] if len(chain) > 1 else chain[0]  # measurement seen by the k_p path
        xi_k = chain[-1]                                 # measurement seen by the controller state
        ah = self.D_k @ xi_p
        ah[:, off_k:] += self.C_k
        A[off_k:, off_k:] += self.A_k
        A[off_k:] += self.B_k @ xi_k
        A[:n_p, :n_p] += self.A_p
        A[:n_p] += self.B_p @ ah
        # break points: b (injection into the state derivative) and c (the computed signal)
        b_h = np.zeros(N)
        b_h[:n_p] = self.B_p[:, 0]
        t_r, t_a = self.torque_rows()
        c_tau = t_a @ ah
        c_tau[: len(self.rigid_states)] += t_r
        b_tau = np.zeros(N)
        b_tau[:n_p] = self.torque_injection()
        names = list(self.plant_states)
        for i, nd in enumerate(n_d):
            names += [f"delay{i + 1}_{j}" for j in range(nd)]
        names += list(self.controller_states)
        return ClosedLoop(A, tuple(names), {"horizontal": (b_h, ah[0].copy()), "attitude": (b_tau, c_tau)})

    @property
    def A(self) -> np.ndarray:
        """Closed-loop matrix with a continuous measurement (states :attr:`closed_loop_states`) [1/s]."""
        return self.closed_loop(None).A

    @property
    def closed_loop_states(self) -> tuple[str, ...]:
        return self.plant_states + self.controller_states


def hover_params(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, tilt_limit_deg: float,
                  tau_motor_s: float | None) -> SimParams:
    # motor lag on: the rotor states then expose the rotor-speed command (module docstring)
    opts = SimOptions(model="full", motor_lag=True, sample_hold=True, inner=inner, tilt_limit_deg=tilt_limit_deg,
                      tau_motor_s=tau_motor_s)
    return SimParams.from_options(vehicle, gains, opts)


def allocation_jacobian(params: SimParams) -> np.ndarray:
    """``∂ω_cmd/∂(u1, τ)`` of :func:`nniquad.control.inner_loops.allocate` at hover, nominal parameters.

    Parameters
    ----------
    params
        Parameter set; the controller's nominal ``m, g, l, b, d`` and frame and the plant's ``ω_max``
        (the limit the simulator's allocation uses) are read.

    Returns
    -------
    ndarray (4, 4)
        Columns: collective thrust [N], roll, pitch, yaw torque [N m].
    """
    u = ca.SX.sym("u", 4)
    nom = params.nominal
    w, _ = IL.allocate(u[0], u[1:4], [getattr(nom, name) for name in PARAM_NAMES], params.plant.omega_max)
    jac = ca.Function("alloc_jac", [u], [ca.jacobian(w, u)])
    hover = np.array([nom.m * nom.g, 0.0, 0.0, 0.0])
    return np.asarray(jac(hover), float)


def linearise_cascade(
    vehicle: Vehicle,
    gains: GainBlock,
    inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS,
    *,
    motor_lag: bool = True,
    tilt_limit_deg: float | None = None,
    tau_motor_s: float | None = None,
) -> LinearCascade:
    """Linearise the full closed loop at hover and split it into plant, controller and motors.

    Parameters
    ----------
    vehicle
        Vehicle (controller's nominal model = plant).
    gains
        Horizontal NNI gains.
    inner
        Inner-loop gains (attitude, yaw, altitude).
    motor_lag
        Keep the first-order motor lag in the plant.
    tilt_limit_deg
        Tilt limit [deg] (inactive at hover; default :data:`nniquad.config.TILT_LIMIT_DEG`).
    tau_motor_s
        Motor time constant [s]; ``None`` takes the vehicle's.

    Returns
    -------
    LinearCascade

    Raises
    ------
    CascadeError
        No equilibrium at hover, or the plant/controller split is not exact.
    """
    params = hover_params(vehicle, gains, inner, TILT_LIMIT_DEG if tilt_limit_deg is None else tilt_limit_deg,
                           tau_motor_s)
    lin = linearise("full", params)
    split = split_cascade(lin.J[None], lin.Y[None], lin.state_names, params.gains.law.sim_state_names)
    rigid, motors, ctrl = split.rigid, split.motors, split.controller
    ir, iw = split.ir, split.iw
    J = lin.J
    A_k, B_k, C_k, D_k = split.A_k, split.B_k, split.C_k, split.D_k
    B_w = split.B_p[0][len(ir):]  # the motor rows of the plant's input matrix
    tau_m = params.plant.tau_motor
    A_rr, A_rw = J[np.ix_(ir, ir)], J[np.ix_(ir, iw)]
    A_wr, A_ww = J[np.ix_(iw, ir)], J[np.ix_(iw, iw)]
    if _split_residual(A_ww * tau_m, -np.eye(4)) > SPLIT_TOL:
        raise CascadeError("the rotor-speed command depends on the rotor speeds; the motor split is not exact")
    W_r, W_a = tau_m * A_wr, tau_m * B_w  # ω_cmd = τ_m ω' + ω
    pos = [rigid.index("x"), rigid.index("y")]
    if motor_lag:
        A_p, B_p = split.A_p[0], split.B_p[0]
        plant = rigid + motors
    else:
        A_p, B_p = A_rr + A_rw @ W_r, A_rw @ W_a
        plant = rigid
    C_p = np.zeros((2, len(plant)))
    C_p[0, pos[0]] = C_p[1, pos[1]] = 1.0
    return LinearCascade(
        vehicle=vehicle, gains=gains, inner=inner, motor_lag=bool(motor_lag), lin=lin,
        plant_states=plant, rigid_states=rigid, controller_states=ctrl,
        A_p=A_p, B_p=B_p, C_p=C_p, A_k=A_k, B_k=B_k, C_k=C_k, D_k=D_k,
        W_r=W_r, W_a=W_a, A_rw=A_rw, tau_motor=tau_m, M_alloc=allocation_jacobian(params),
    )
