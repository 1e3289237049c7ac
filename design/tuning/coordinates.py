"""The tuner's search coordinates: the box, the attitude limits, and the maps between coordinates and gains."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Sequence

import numpy as np

from nniquad import config
from nniquad.config import DT_S
from nniquad.control.gains import DEFAULT_INNER_LOOP_GAINS, Gains, InnerLoopGains
from nniquad.control.inner_loops import attitude_wn_limit
from nniquad.model.vehicle import Vehicle
from nniquad.tuning.options import TuneOptions


# ----------------------------------------------------------------------------- coordinates


def search_box(options: TuneOptions, dt_s: float = DT_S) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the search coordinates (see the module docstring).

    kp in [0.5, 2000] 1/s², u in [0, 4] (γ from γ_max down to γ_max e⁻⁴),
    Γδ in [0.05, 2.5/dt] 1/s; ω_a in [10, 150] rad/s, ζ_a in [0.5, 1.5],
    α/α_avail in [0.1, 1].

    Parameters
    ----------
    options
        The tuning options (the model decides the dimension).
    dt_s
        RK4 step [s]; bounds the controller pole Gamma delta <= 2.5/dt.
    """
    lo = [math.log(0.5), 0.0, math.log(0.05)]
    hi = [math.log(2000.0), 4.0, math.log(2.5 / dt_s)]
    if options.dims == 6:
        lo += [math.log(10.0), 0.5, 0.1]
        hi += [math.log(150.0), 1.5, 1.0]
    return np.array(lo), np.array(hi)


def attitude_accel_headroom(vehicle: Vehicle, tilt_limit_deg: float) -> float:
    """Roll angular acceleration the rotors can still give at the tilt limit [rad/s²].

    Holding altitude at tilt ``T`` needs ``c = m g / (4 cos T)`` per rotor; a roll
    torque moves a pair apart by ``±r`` with ``r <= min(c, T_max - c)``, so
    ``α_avail = 2 l min(c, T_max - c) / J_x`` (the smaller of roll and pitch).

    Parameters
    ----------
    vehicle
        The vehicle (mass, arm, rotor limits, inertias).
    tilt_limit_deg
        Tilt limit [deg].
    """
    c = vehicle.m * vehicle.g / (4.0 * math.cos(math.radians(tilt_limit_deg)))
    t_max = vehicle.b * vehicle.omega_max**2
    return 2.0 * vehicle.l * max(min(c, t_max - c), 0.0) / max(vehicle.Jx, vehicle.Jy)


def attitude_wn_cap(tau_motor_s: float | None, zeta: float) -> float:
    """Largest attitude natural frequency the tuner may choose [rad/s] (``inf`` without motor lag).

    :func:`nniquad.control.inner_loops.attitude_wn_limit` at the slowest motor of the
    Monte Carlo range (``config.TAU_MOTOR_FACTOR_RANGE[1]`` × nominal) with gain margin
    ``config.ATTITUDE_GAIN_MARGIN``.  Without it the sweep drove ω_a to ~100 rad/s, at the
    Routh limit ``2 ζ_a/τ_m`` of the *nominal* motor: every slower motor then put the
    attitude loop into a limit cycle on the rotor limits (FINDINGS.md).

    Parameters
    ----------
    tau_motor_s
        Nominal motor time constant [s], or None for a model without motor lag.
    zeta
        Attitude damping ratio.

    Returns
    -------
    float
        The cap [rad/s].
    """
    if tau_motor_s is None:
        return math.inf
    return attitude_wn_limit(tau_motor_s, zeta, config.TAU_MOTOR_FACTOR_RANGE[1], config.ATTITUDE_GAIN_MARGIN)


def decode(q: Sequence[float], m: float, gamma_max: float,
           inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS, alpha_avail: float = 1.0,
           tau_motor_s: float | None = None) -> tuple[Gains, InnerLoopGains]:
    """Search coordinates → gains (and inner-loop gains when ``q`` has 6 entries).

    Parameters
    ----------
    q
        Search coordinates (3, or 6 with the attitude loop).
    m
        Nominal mass [kg].
    gamma_max
        Ceiling of the sector bound.
    inner
        Inner-loop gains to start from (the attitude fields are replaced with 6 coordinates).
    alpha_avail
        Attitude acceleration headroom [rad/s^2] (:func:`attitude_accel_headroom`).
    tau_motor_s
        Nominal motor time constant [s]; when given, ω_a is capped at :func:`attitude_wn_cap`.
    """
    kp = math.exp(q[0])
    delta = math.exp(q[1]) / (gamma_max * m * kp)
    Gamma = math.exp(q[2]) / delta
    if len(q) > 3:
        wn = min(math.exp(q[3]), attitude_wn_cap(tau_motor_s, float(q[4])))
        inner = replace(inner, attitude_wn_rad_s=wn, attitude_zeta=float(q[4]),
                        attitude_accel_limit_rad_s2=float(q[5]) * alpha_avail)
    return Gains(kp=kp, Gamma=Gamma, delta=delta), inner


def encode(gains: Gains, m: float, gamma_max: float, inner: InnerLoopGains | None = None,
           alpha_avail: float = 1.0) -> np.ndarray:
    """Inverse of :func:`decode`.

    Parameters
    ----------
    gains
        The NNI gains.
    m
        Nominal mass [kg].
    gamma_max
        Ceiling of the sector bound.
    inner
        Inner-loop gains (adds the 3 attitude coordinates), or ``None``.
    alpha_avail
        Attitude acceleration headroom [rad/s^2].
    """
    q = [math.log(gains.kp), math.log(gamma_max * m * gains.kp * gains.delta), math.log(gains.Gamma * gains.delta)]
    if inner is not None:
        q += [math.log(inner.attitude_wn_rad_s), inner.attitude_zeta,
              inner.attitude_accel_limit_rad_s2 / alpha_avail]
    return np.array(q)
