"""A certified bound on the tracking error of the sampled cascade, for every reference of a class.

The model
---------
The certificate's model: the simulator's full closed loop linearised at hover (rigid body, attitude PD in its
linear region, allocation, first-order motor lag; :mod:`nniquad.analysis.cascade.family`), the position sampled
at the certificate's rate and held, the law run in discrete time (its exact ZOH equivalent, its command held over
the period: variant ``"discrete"``), the attitude loop and the motors continuous.  At hover the loop splits into
an x and a y axis that do not feed each other (:func:`nniquad.analysis.cascade.family.mode_transform`); each axis
has the plant ``p' = A_p p + B_p a_h`` (position, velocity, tilt, tilt rate, the rotor pair's mode) and the law
``z_{k+1} = A_kd z_k + B_kd e_k``, ``u_k = C_k z_k + D_k e_k``, ``e_k = C_p p(kT) - x_d(kT)`` (it reads the
position error only).

Without feedforward
-------------------
The law's command is ``a_h = u_k``.  A ramp ``x_d = x_0 + v t`` is followed exactly by ``p = Π r`` (position
``x_d``, velocity ``v``, the rest zero; ``A_p Π = Π S`` with ``S`` the ramp's generator: nothing at hover depends
on the position or, without drag, on the velocity), with ``z = 0`` and ``u = 0``.  In the error coordinates
``p̃ = p - Π (x_d, v_d)``::

    p̃' = A_p p̃ + B_p u(t) - e_v ẍ_d(t),      e = x - x_d = C_p p̃,

``e_v`` the unit velocity state: the error is driven by the reference's acceleration alone, through a stable
sampled-data loop, from ``p̃ = 0`` when the run starts on the reference (position and velocity, level, rotors
at hover, law state 0).  So ``|e(t)| <= γ_A A`` for every ``|ẍ_d| <= A``, ``γ_A`` the loop's peak-to-peak
gain (:func:`nniquad.analysis.tracking_l1.peak_gain`: exact ZOH on a fine grid, explicit intersample and
in-step error terms, a Lyapunov-certified tail).

With feedforward
----------------
The command is ``a_h = u_k + ẍ_d(kT)``, the reference's acceleration sampled with the position and held over the
period (what a sampled controller runs).  Write ``d(t) = ẍ_d(kT) - ẍ_d(t)`` (``d' = -x⃛_d``, reset to 0 at
every sample) and let ``w`` solve ``A_p w + B_p = c e_v``, ``C_p w = 0``: the inner loop's steady state under a
constant unit command, which accelerates the vehicle at ``c`` (``c = 1`` when the inner loop's DC gain is one:
the nominal vehicle).  In ``p̂ = p̃ - w ẍ_d``::

    p̂' = A_p p̂ + B_p (u + d) + (c - 1) e_v ẍ_d - w x⃛_d,    d' = -x⃛_d,    e = C_p p̂.

The error is driven by the jerk (the inner loop's lag behind a changing acceleration, and the hold's), by the DC
mismatch ``(c - 1) ẍ_d`` (zero for the nominal vehicle), and starts from ``p̂(0) = -w ẍ_d(0)`` (the vehicle
level while the reference already accelerates).  So ``|e| <= γ_J J + |c - 1| γ_A A + γ_0 |ẍ_d(0)|`` for
``|x⃛_d| <= J``, ``|ẍ_d| <= A``, ``γ_0`` the peak of the free response from ``-w``.

The linear zone
---------------
The bound holds while the tilt limit is inactive: the command's norm stays below ``L = f_m g tan(tilt)`` (the
lowest mass factor covered).  The command is an output of the same loops, so ``|u| <= γ_u A`` without
feedforward and ``|u + ẍ_d(kT)| <= A + γ_uJ J + |c - 1| γ_uA A + γ_u0 A`` with it: when that stays below ``L``
for the class, every reference of the class stays in the zone (:attr:`TrackingBound.zone_holds`).

Per axis or Euclidean
---------------------
The class is ``‖ẍ_d(t)‖₂ <= A`` (and ``‖x⃛_d(t)‖₂ <= J``), so each axis's component is within it and each axis's
error obeys its bound.  When the two axes have the same loop (the nominal vehicle: ``J_x = J_y``), ``e(t) =
∫ h(t, τ) ẍ_d(τ) dτ`` with a scalar ``h``, so ``‖e‖ <= ∫|h| ‖ẍ_d‖`` and the Euclidean bound is the per-axis one;
otherwise (box corners with ``J_x ≠ J_y``) it is ``√2`` times the larger per-axis bound.  The command's bound is
combined the same way.  "The same loop" is the same matrices to :data:`KERNEL_RTOL` (relative, after a ±1 sign
per state): the two axes of a symmetric vehicle differ only by the ``O(ε²)`` rounding of the symmetric-mean
Jacobian (``1e-10``), the precision of the model itself, and then share one computation.

What is covered
---------------
The nominal vehicle, and with ``box`` every corner of the certificate's parameter box (the worst is stated):
a bound at the corners, not between them.  The linearisation at hover is the certificate's model: the rigid
body's nonlinearity (``tan`` of the tilt, rotor speeds squared) and the attitude shaping beyond its linear
region are outside it, as they are outside the cascade certificate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Sequence

import numpy as np

from nniquad.analysis.cascade.box import ParameterBox, tilt_accel_limit
from nniquad.analysis.cascade.family import CascadeFamily, mode_transform, sampled_family, subsystems
from nniquad.analysis.tracking_l1 import FINE_STEPS, HybridLoop, PeakGain, peak_free, peak_gain
from nniquad.config import CONTROL_RATE_HZ, TILT_LIMIT_DEG, TRACKING_ACCEL_LIMIT_M_S2, TRACKING_JERK_LIMIT_M_S3
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CascadeError, InputError
from nniquad.laws.base import GainBlock
from nniquad.model.vehicle import Vehicle

__all__ = ["AxisLoop", "TrackingBound", "ReferenceClass", "axis_loops", "tracking_bound", "classify_reference",
           "METHOD", "DECOUPLING_TOL", "KERNEL_RTOL"]

#: How the bound is obtained (stated in the certificate).
METHOD = ("peak-to-peak (L1 kernel) gain of the sampled-data error loop: exact ZOH on a fine grid of each "
          "period, explicit in-step and intersample Taylor error terms, the sum over past periods closed by a "
          "Lyapunov-certified geometric tail")
#: Largest coupling (relative) between the axis block and the rest of the linearised plant.
DECOUPLING_TOL = 1e-7
#: Relative agreement of two axis loops' matrices for them to count as the same loop (module docstring).
KERNEL_RTOL = 1e-8
#: A class limit is exceeded when a sample is above it by more than this fraction (rounding of the samples).
CLASS_RTOL = 1e-9


@dataclass(frozen=True)
class AxisLoop:
    """One horizontal axis of the linearised sampled cascade (module docstring).

    Attributes
    ----------
    A_p, B_p, C_p
        Plant ``p' = A_p p + B_p a_h`` (``B_p`` a vector), position ``C_p p`` (a row).
    velocity : int
        Index of the velocity state.
    A_kd, B_kd, C_k, D_k
        The law in discrete time on this axis (``B_kd`` a vector, ``C_k`` a row, ``D_k`` a scalar).
    T
        Sample period [s].
    plant_states, law_states
        Names.
    """

    A_p: np.ndarray
    B_p: np.ndarray
    C_p: np.ndarray
    velocity: int
    A_kd: np.ndarray
    B_kd: np.ndarray
    C_k: np.ndarray
    D_k: float
    T: float
    plant_states: tuple[str, ...]
    law_states: tuple[str, ...]

    def steady_accelerating(self) -> tuple[np.ndarray, float]:
        """``(w, c)``: ``A_p w + B_p = c e_v``, ``C_p w = 0`` (the inner loop's steady state under a unit command).

        Raises
        ------
        CascadeError
            No such steady state (the equations are inconsistent).
        """
        n = len(self.B_p)
        e_v = np.zeros(n)
        e_v[self.velocity] = 1.0
        M = np.vstack([np.column_stack([self.A_p, -e_v]), np.append(self.C_p, 0.0)])
        rhs = np.append(-self.B_p, 0.0)
        sol, *_ = np.linalg.lstsq(M, rhs, rcond=None)
        if np.linalg.norm(M @ sol - rhs) > 1e-9 * max(1.0, float(np.linalg.norm(rhs))):
            raise CascadeError("the inner loop has no steady accelerating state: no feedforward bound")
        return sol[:n], float(sol[n])

    def hybrid(self, feedforward: bool) -> tuple[HybridLoop, np.ndarray]:
        """The error loop as a :class:`HybridLoop` driven by ``ẍ_d`` (without) or ``x⃛_d`` (with feedforward).

        State: the plant (``p̃`` or ``p̂``), with feedforward the hold's mismatch ``d``, the law's state, the held
        command ``a_h``.  At a sample the law reads ``e_k``, holds ``u_k = C_k z_k + D_k e_k`` and updates ``z``;
        ``d`` restarts at 0 (module docstring).

        Parameters
        ----------
        feedforward
            With the held acceleration feedforward.

        Returns
        -------
        loop, w
            The loop and ``w`` (zero without feedforward).
        """
        n_p, n_k = len(self.B_p), self.A_kd.shape[0]
        nd = 1 if feedforward else 0
        n = n_p + nd + n_k + 1
        ip, iu = slice(0, n_p), n - 1
        ik = slice(n_p + nd, n_p + nd + n_k)
        A = np.zeros((n, n))
        A[ip, ip] = self.A_p
        A[ip, iu] = self.B_p
        b = np.zeros(n)
        if feedforward:
            w, _ = self.steady_accelerating()
            A[ip, n_p] = self.B_p
            b[ip], b[n_p] = -w, -1.0
        else:
            w = np.zeros(n_p)
            b[self.velocity] = -1.0
        Jm = np.eye(n)
        Jm[ik, ik] = self.A_kd
        Jm[ik, ip] = np.outer(self.B_kd, self.C_p)
        Jm[iu, :] = 0.0
        Jm[iu, ik] = self.C_k
        Jm[iu, ip] = self.D_k * self.C_p
        if feedforward:
            Jm[n_p, :] = 0.0  # the held feedforward is re-sampled: d(kT⁺) = 0
        names = self.plant_states + (("ff_hold",) if feedforward else ()) + self.law_states + ("a_h",)
        return HybridLoop(A, b, Jm, self.T, names), w


def axis_loops(family: CascadeFamily, index: int) -> dict[str, AxisLoop]:
    """The x and y :class:`AxisLoop` of point ``index`` of a family.

    Raises
    ------
    CascadeError
        An axis is coupled to the rest of the plant beyond :data:`DECOUPLING_TOL`.
    """
    Tm, names = mode_transform(family.state_names, family.frame)
    subs = subsystems(family.state_names)
    n_p = family.A_p.shape[1]
    law = set(family.state_names[n_p:])
    rows = {s: i for i, s in enumerate(names)}
    Rp_all = Tm[:, :n_p]
    Rk_all = Tm[:, n_p:]
    A_full = Rp_all @ family.A_p[index] @ Rp_all.T
    A_kd, B_kd = family.A_kd, family.B_kd
    out = {}
    for a, axis in enumerate(("x", "y")):
        plant = tuple(s for s in subs[axis] if s not in law)
        ctrl = tuple(s for s in subs[axis] if s in law)
        ip = [rows[s] for s in plant]
        rest = [i for i in range(Tm.shape[0]) if i not in ip]
        Ap = A_full[np.ix_(ip, ip)]
        leak = max(np.max(np.abs(A_full[np.ix_(ip, rest)])), np.max(np.abs(A_full[np.ix_(rest, ip)])))
        if leak > DECOUPLING_TOL * max(1.0, float(np.max(np.abs(Ap)))):
            raise CascadeError(f"the {axis} axis is coupled to the rest of the plant (relative {leak:.3g})")
        Rp = Rp_all[ip]
        Rk = Rk_all[[rows[s] for s in ctrl]]
        Bp = Rp @ family.B_p[index][:, a]
        # a sign per state along the chain position -> velocity -> tilt -> ... (a diagonal ±1 similarity, which
        # keeps the position and velocity): the y axis then reads like the x axis, and equal axes share one result
        sg = np.ones(len(plant))
        for k in range(1, len(plant)):
            sg[k] = sg[k - 1] * (-1.0 if Ap[k - 1, k] < 0 else 1.0)
        Ap, Bp = sg[:, None] * Ap * sg[None, :], sg * Bp
        # the ramp is followed exactly (module docstring): position integrates velocity, neither feeds back
        ramp = np.zeros_like(Ap[:, :2])
        ramp[0, 1] = 1.0
        if np.max(np.abs(Ap[:, :2] - ramp)) > DECOUPLING_TOL * max(1.0, float(np.max(np.abs(Ap)))):
            raise CascadeError(f"the {axis} axis's dynamics depend on its position or velocity: a ramp is not "
                               "followed exactly and the error loop does not hold")
        Cp = np.zeros(len(plant))
        Cp[0] = 1.0
        out[axis] = AxisLoop(A_p=Ap, B_p=Bp, C_p=Cp, velocity=1, A_kd=Rk @ A_kd @ Rk.T, B_kd=Rk @ B_kd[:, a],
                             C_k=family.C_k[a] @ Rk.T, D_k=float(family.D_k[a, a]), T=family.T,
                             plant_states=plant, law_states=ctrl)
    return out


@dataclass(frozen=True)
class _AxisGains:
    """Peak gains of one axis (per unit of the class limits)."""

    accel: PeakGain          # e and u per m/s² of ẍ_d, without feedforward
    jerk: PeakGain           # e and u per m/s³ of x⃛_d, with feedforward
    dc_gain: float           # c
    initial: tuple[float, float]  # (e, u) peaks of the free response from p̂ = -w (per m/s² of ẍ_d(0))


def _loop_key(loop: AxisLoop) -> bytes:
    """The loop's matrices to :data:`KERNEL_RTOL` (relative): equal keys are the same loop (module docstring)."""
    parts = [loop.A_p, loop.B_p, loop.A_kd, loop.B_kd, loop.C_k, np.array([loop.D_k])]
    return b"".join((np.round(np.asarray(M, float) / max(float(np.max(np.abs(M))), 1e-300) / KERNEL_RTOL) + 0.0).tobytes()
                    for M in parts)


def _axis_gains(axis: AxisLoop, fine_steps: int) -> _AxisGains:
    loop_a, _ = axis.hybrid(False)
    ga = peak_gain(loop_a, loop_a.row(axis.plant_states[0]), loop_a.row("a_h"), fine_steps=fine_steps)
    loop_j, w = axis.hybrid(True)
    gj = peak_gain(loop_j, loop_j.row(axis.plant_states[0]), loop_j.row("a_h"), fine_steps=fine_steps)
    _, c = axis.steady_accelerating()
    z0 = np.zeros(len(loop_j.b))
    z0[:len(w)] = -w
    e0 = peak_free(loop_j, loop_j.row(axis.plant_states[0]), z0, fine_steps=fine_steps)
    u0 = peak_free(loop_j, loop_j.row("a_h"), z0, fine_steps=fine_steps, held=True)
    return _AxisGains(ga, gj, c, (e0, u0))


@dataclass(frozen=True)
class TrackingBound:
    """The certified tracking-error bound of a design for a class of references (module docstring).

    Attributes
    ----------
    accel_limit_m_s2, jerk_limit_m_s3
        The class: ``‖ẍ_d‖₂ <= A`` [m/s²], and with feedforward ``‖x⃛_d‖₂ <= J`` [m/s³].
    bound_m
        ``{"no_feedforward": …, "feedforward": …}``: the Euclidean bound on ``‖ξ_h - ξ_h^d‖`` [m] over the class.
    per_axis_m
        The same per axis (the larger of x and y) [m].
    gains
        Per unit of the class limits, the worst over what is covered: ``accel_m_per_m_s2`` (no feedforward),
        ``jerk_m_per_m_s3``, ``dc_mismatch`` (``|c - 1|``), ``initial_m_per_m_s2`` (feedforward), and the
        command's ``command_accel``, ``command_jerk_per_s``, ``command_initial``.
    axes_identical
        Whether the x and y kernels coincide (Euclidean = per axis); else the factor √2.
    command_bound_m_s2
        ``{"no_feedforward": …, "feedforward": …}``: the bound on the command's norm before the tilt limit [m/s²].
    zone_limit_m_s2
        ``L``: the tilt limit as a command norm at the lowest mass covered [m/s²].
    rate_hz
        Control rate.
    covers
        What is covered (text), ``points`` the parameter points (factors, :data:`nniquad.analysis.cascade.box.POINT_NAMES`).
    method
        :data:`METHOD`.
    fine_steps, contraction, periods
        The computation's grid, its worst tail contraction (per period) and longest sum.
    """

    accel_limit_m_s2: float
    jerk_limit_m_s3: float
    bound_m: dict[str, float]
    per_axis_m: dict[str, float]
    gains: dict[str, float]
    axes_identical: bool
    command_bound_m_s2: dict[str, float]
    zone_limit_m_s2: float
    rate_hz: float
    covers: str
    points: list[list[float]]
    method: str = METHOD
    fine_steps: int = FINE_STEPS
    contraction: float = math.nan
    periods: int = 0

    @property
    def euclidean_factor(self) -> float:
        return 1.0 if self.axes_identical else math.sqrt(2.0)

    @property
    def zone_holds(self) -> dict[str, bool]:
        """Whether every reference of the class keeps the command below the tilt limit, per case."""
        return {k: v <= self.zone_limit_m_s2 for k, v in self.command_bound_m_s2.items()}

    @property
    def zone_accel_limit_m_s2(self) -> dict[str, float]:
        """The largest acceleration limit ``A`` [m/s²] for which the command stays below the tilt limit (for the
        stated ``J`` with feedforward; the start ``‖ẍ_d(t0)‖ <= A``): :meth:`command_for` solved for ``A``."""
        g, f, L = self.gains, self.euclidean_factor, self.zone_limit_m_s2
        ff = (L - f * g["command_jerk_per_s"] * self.jerk_limit_m_s3) / (
            1.0 + f * (g["dc_mismatch"] * g["command_accel"] + g["command_initial"]))
        return {"no_feedforward": L / (f * g["command_accel"]), "feedforward": max(ff, 0.0)}

    def bound_for(self, accel: float, jerk: float, initial_accel: float) -> dict[str, float]:
        """The Euclidean bounds [m] for a reference with these peaks (``‖ẍ_d‖``, ``‖x⃛_d‖``, ``‖ẍ_d(t0)‖``)."""
        g, f = self.gains, self.euclidean_factor
        return {"no_feedforward": f * g["accel_m_per_m_s2"] * accel,
                "feedforward": f * (g["jerk_m_per_m_s3"] * jerk + g["dc_mismatch"] * g["accel_m_per_m_s2"] * accel
                                    + g["initial_m_per_m_s2"] * initial_accel)}

    def command_for(self, accel: float, jerk: float, initial_accel: float) -> dict[str, float]:
        """The bounds on the command's norm [m/s²] for a reference with these peaks."""
        g, f = self.gains, self.euclidean_factor
        return {"no_feedforward": f * g["command_accel"] * accel,
                "feedforward": accel + f * (g["command_jerk_per_s"] * jerk
                                            + g["dc_mismatch"] * g["command_accel"] * accel
                                            + g["command_initial"] * initial_accel)}


def tracking_bound(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, *,
                   rate_hz: float = CONTROL_RATE_HZ, tilt_limit_deg: float = TILT_LIMIT_DEG,
                   accel_limit: float = TRACKING_ACCEL_LIMIT_M_S2, jerk_limit: float = TRACKING_JERK_LIMIT_M_S3,
                   box: ParameterBox | None = None, fine_steps: int = FINE_STEPS) -> TrackingBound:
    """The tracking-error bounds of a design for the class ``‖ẍ_d‖ <= A``, ``‖x⃛_d‖ <= J`` (module docstring).

    Parameters
    ----------
    vehicle, gains, inner
        The certified design.
    rate_hz
        Control rate [Hz].
    tilt_limit_deg
        Tilt limit [deg] (the linear zone).
    accel_limit, jerk_limit
        ``A`` [m/s²] and ``J`` [m/s³].
    box
        With a box: its corners too (the worst is stated), else the nominal vehicle alone.
    fine_steps
        Fine steps per period of the peak gains.

    Returns
    -------
    TrackingBound

    Raises
    ------
    InputError
        A class limit that is not a finite number >= 0.
    CascadeError
        An unstable loop, coupled axes, no steady accelerating state.
    """
    for name, v in (("acceleration limit", accel_limit), ("jerk limit", jerk_limit)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise InputError(f"the tracking class's {name} must be a finite number >= 0, got {v!r}")
    pts = np.ones((1, 6)) if box is None else np.vstack([np.ones((1, 6)), box.vertices()])
    fam = sampled_family(vehicle, gains, inner, pts, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz)
    seen: dict[bytes, _AxisGains] = {}
    worst: dict[str, float] = {}
    identical, rho, periods = True, 0.0, 0
    for i in range(len(fam)):
        per, keys = {}, []
        for axis, loop in axis_loops(fam, i).items():
            keys.append(_loop_key(loop))
            if keys[-1] not in seen:
                seen[keys[-1]] = _axis_gains(loop, fine_steps)
            per[axis] = seen[keys[-1]]
        identical &= keys[0] == keys[1]
        for ag in per.values():
            vals = {"accel_m_per_m_s2": ag.accel.continuous, "jerk_m_per_m_s3": ag.jerk.continuous,
                    "dc_mismatch": abs(ag.dc_gain - 1.0), "initial_m_per_m_s2": ag.initial[0],
                    "command_accel": ag.accel.held, "command_jerk_per_s": ag.jerk.held,
                    "command_initial": ag.initial[1]}
            for k, v in vals.items():
                worst[k] = max(worst.get(k, 0.0), float(v))
            rho = max(rho, ag.accel.contraction, ag.jerk.contraction)
            periods = max(periods, ag.accel.periods, ag.jerk.periods)
    A, J = float(accel_limit), float(jerk_limit)
    L = tilt_accel_limit(vehicle, box if box is not None else ParameterBox(), tilt_limit_deg)
    covers = ("the nominal vehicle" if box is None else
              f"the nominal vehicle and the {len(pts) - 1} corners of the certificate's box (not between them)")
    tb = TrackingBound(accel_limit_m_s2=A, jerk_limit_m_s3=J, bound_m={}, per_axis_m={}, gains=worst,
                       axes_identical=identical, command_bound_m_s2={}, zone_limit_m_s2=L, rate_hz=float(rate_hz),
                       covers=covers, points=pts.tolist(), fine_steps=fine_steps, contraction=rho, periods=periods)
    b = tb.bound_for(A, J, A)   # the worst start of the class: ‖ẍ_d(t0)‖ = A
    return replace(tb, bound_m=b, per_axis_m={k: v / tb.euclidean_factor for k, v in b.items()},
                   command_bound_m_s2=tb.command_for(A, J, A))


@dataclass(frozen=True)
class ReferenceClass:
    """Whether a sampled reference lies in a bound's class and zone.

    Attributes
    ----------
    inside
        ``{"no_feedforward": …, "feedforward": …}``: in the class and, for the reference's own peaks, in the zone.
    max_accel_m_s2, max_jerk_m_s3, initial_accel_m_s2
        The reference's peaks over the samples (the jerk from the given samples, or from differences of the
        acceleration: then a lower estimate of the true peak between the samples).
    bound_m, command_m_s2
        The bounds for the reference's own peaks.
    reasons
        Why a case is outside (empty when inside).
    """

    inside: dict[str, bool]
    max_accel_m_s2: float
    max_jerk_m_s3: float
    initial_accel_m_s2: float
    bound_m: dict[str, float]
    command_m_s2: dict[str, float]
    reasons: dict[str, list[str]]


def _samples(name: str, a: Any, n: int | None) -> np.ndarray:
    arr = np.asarray(a, float)
    arr = arr.reshape(-1, 1) if arr.ndim == 1 else arr
    if arr.ndim != 2 or arr.shape[1] not in (1, 2) or (n is not None and arr.shape[0] != n) or arr.shape[0] < 2:
        raise InputError(f"reference {name} must be {n if n else 'N >= 2'} samples of 1 or 2 axes, got shape "
                         f"{np.shape(a)}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"reference {name} has a value that is not finite")
    return arr


def classify_reference(bound: TrackingBound, t: Sequence[float], x_d: Any, v_d: Any, a_d: Any,
                       jerk: Any | None = None) -> ReferenceClass:
    """Whether a sampled reference is of the bound's class and keeps the command in the linear zone.

    The bound also assumes its start (:data:`nniquad.analysis.tracking_section.START`: the run begins on the
    reference, level, the law at rest); that is the run's, not the reference's, and is not checked here.

    Parameters
    ----------
    bound
        The bound (its class limits and gains).
    t
        Sample times [s], increasing.
    x_d, v_d, a_d
        Position [m], velocity [m/s], acceleration [m/s²]: ``(N,)`` or ``(N, 2)``.
    jerk
        Jerk [m/s³]; ``None`` estimates it from differences of ``a_d``.

    Returns
    -------
    ReferenceClass

    Raises
    ------
    InputError
        Arrays of the wrong shape, times not increasing.
    """
    tt = np.asarray(t, float).ravel()
    if tt.size < 2 or not np.all(np.isfinite(tt)) or not np.all(np.diff(tt) > 0):
        raise InputError("reference times must be at least 2 finite, increasing samples")
    n = tt.size
    _samples("position", x_d, n)
    _samples("velocity", v_d, n)
    a = _samples("acceleration", a_d, n)
    j = _samples("jerk", jerk, n) if jerk is not None else np.diff(a, axis=0) / np.diff(tt)[:, None]
    acc = float(np.max(np.linalg.norm(a, axis=1)))
    jmax = float(np.max(np.linalg.norm(j, axis=1)))
    a0 = float(np.linalg.norm(a[0]))
    inside, reasons = {}, {}
    bnd = bound.bound_for(acc, jmax, a0)
    cmd = bound.command_for(acc, jmax, a0)
    for case in ("no_feedforward", "feedforward"):
        why = []
        if acc > bound.accel_limit_m_s2 * (1 + CLASS_RTOL):
            why.append(f"acceleration {acc:.4g} m/s² above the class's {bound.accel_limit_m_s2:.4g} m/s²")
        if case == "feedforward" and jmax > bound.jerk_limit_m_s3 * (1 + CLASS_RTOL):
            why.append(f"jerk {jmax:.4g} m/s³ above the class's {bound.jerk_limit_m_s3:.4g} m/s³")
        if cmd[case] > bound.zone_limit_m_s2:
            why.append(f"command up to {cmd[case]:.4g} m/s² may reach the tilt limit's {bound.zone_limit_m_s2:.4g} m/s²")
        inside[case], reasons[case] = not why, why
    return ReferenceClass(inside, acc, jmax, a0, bnd, cmd, reasons)
