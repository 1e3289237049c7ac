"""The loops the paper assumes but does not specify, as CasADi ``SX`` expressions.

The paper closes only the horizontal loop: an acceleration command
``a_h = -K_p ξ + z/m`` (its inner proportional loop plus the NNI controller
output, positive feedback).  A real vehicle needs four more pieces to turn that
command into rotor speeds.  Each is written here once, as a pure function of
CasADi symbols, and documented with its gains (:class:`InnerLoopGains`).

Frames: NED inertial frame (z down), FRD body frame, ZYX Euler angles
``η = (φ, θ, ψ)``, thrust ``u1`` along ``-z_B`` -- the frame of
:mod:`nniquad.model.symbolic`.

1. **Altitude hold** (PID on the NED altitude ``z``, reference 0).  Vertical
   acceleration command ``a_z = -(3 ω_z²) z - (3 ω_z) ż - ω_z³ ∫z``, i.e. a
   triple closed-loop pole at ``-ω_z`` for the nominal mass (default
   ``ω_z = 3 rad/s``: gains 27 s⁻², 9 s⁻¹, 27 s⁻³).  It uses the *vertical*
   velocity ``ż`` (a barometer / vertical-speed sensor); no *horizontal*
   velocity is used anywhere.  The integral removes the altitude offset a mass
   error would cause.
2. **Thrust vector and tilt limit.**  The desired specific force is
   ``f = (a_x, a_y, a_z - g)`` (NED).  Let ``g_z = max(g - a_z, 0.2 g)`` (the
   thrust must keep pointing up).  The horizontal command is norm-limited to
   ``‖a_h‖ ≤ g_z tan(T_lim)`` (the vector is scaled down, its direction kept),
   which keeps the *commanded* tilt ``atan(‖a_h‖/g_z)`` at or below ``T_lim``
   exactly.  In the yaw-aligned frame ``b = Rz(-ψ) a_h`` the setpoints are
   ``θ_d = atan2(-b_x, g_z)``, ``φ_d = atan(b_y cos θ_d / g_z)`` (derived in
   :func:`tilt_setpoints`) and the collective thrust is
   ``u1 = m̂ g_z / max(cos φ cos θ, 0.5)`` (tilt compensation, capped at 60°).
3. **Attitude loop** (PD on the Euler angles, damping from the gyro).  With body
   rates ``(p, q, r) = W(η) η̇`` measured by the gyro, the torques are
   ``τ_φ = s Ĵ_x (ω_a² (φ_d - φ) - 2 ζ_a ω_a p)``,
   ``τ_θ = s Ĵ_y (ω_a² (θ_d - θ) - 2 ζ_a ω_a q)`` and the yaw hold at ψ = 0,
   ``τ_ψ = s Ĵ_z (-ω_ψ² ψ - 2 ζ_ψ ω_ψ r)``.  Near hover each axis is the
   second-order lag ``ω_a² / (s² + 2 ζ_a ω_a s + ω_a²)`` from commanded to
   actual angle, hence from commanded to actual horizontal acceleration.
   Defaults: ``ω_a = 25 rad/s``, ``ζ_a = 0.8`` (rise time about 0.1 s, an
   effective delay ``2 ζ_a / ω_a = 64 ms``), ``ω_ψ = 8 rad/s``, ``ζ_ψ = 0.8``.
   ``s`` (default 1) scales all three torques: it models an attitude-gain (or
   inertia-estimate) error for Monte Carlo studies.  Hats are the controller's
   nominal values.

   Written as a cascade, the roll law is ``τ_φ = s Ĵ_x k_r (p_d - p)`` with the
   rate gain ``k_r = 2 ζ_a ω_a`` and the rate demand ``p_d = k e_φ``,
   ``k = ω_a / (2 ζ_a)``.  For large errors the linear demand asks for far more
   torque than the rotors have (a 60° tilt reversal at ω_a = 45 rad/s wants
   about 20 times the available roll torque of the paper's vehicle), the
   torques saturate and the loop overshoots or goes unstable.  The rate demand
   is therefore shaped by the square-root law (:func:`sqrt_shaping`, the rate
   from which a constant deceleration ``α`` stops exactly at the setpoint):
   ``p_d = k e`` for ``|e| <= α/k²`` and ``sign(e) sqrt(2 α (|e| - α/(2k²)))``
   beyond, continuous with a continuous slope.  Small errors see the linear PD
   above unchanged.  ``α`` (``attitude_accel_limit_rad_s2``) defaults to
   ``1e6 rad/s²``, which makes the shaping inactive (the pure PD); the tuner
   sets it from the vehicle's torque headroom at the tilt limit.
4. **Allocation with rotor saturation** (:func:`allocate`).  Rotor thrusts
   ``T_i = b ω_i²`` are limited to ``[0, T_max = b ω_max²]``.  The demand
   ``(u1, τ)`` is split by the columns of the layout's allocation matrix ``B``
   (:func:`nniquad.model.symbolic.allocation_matrix`, the exact inverse of the
   thrust mixer of the vehicle's frame) into a collective ``c = u1/4`` per rotor
   (every layout spreads it evenly), a roll/pitch part ``D_i = B_i1 τ_φ + B_i2 τ_θ``
   and a yaw part ``B_i3 τ_ψ``, so that ``T_i = c + D_i + B_i3 τ_ψ``.  For the '+'
   layout ``D = (q, -r, -q, r)`` with ``r = τ_φ/(2l)``, ``q = τ_θ/(2l)``, and the
   yaw part is ``∓y``, ``y = τ_ψ b/(4d)``; for the 'x' layout every rotor takes
   ``±τ_φ/(2√2 l) ± τ_θ/(2√2 l)``.  Priority: the collective first (it holds the
   altitude), then roll/pitch, yaw last:

   a. roll and pitch are scaled together (direction kept) so that
      ``M = max_i |D_i|`` fits around the demanded collective ``c``:
      ``M ≤ max(min(c, T_max - c), M_res)`` with the reserved attitude
      authority ``M_res = ATTITUDE_RESERVE_FRACTION · T_max/2`` (and always
      ``M ≤ T_max/2``);
   b. the collective is shifted into ``[M, T_max - M]``: it moves only when
      the demand lies within ``M_res`` of a rotor limit (a vehicle near its
      thrust limit keeps a minimum of attitude control, and a vehicle near
      idle a minimum of roll torque);
   c. the yaw torque is clipped to the interval that keeps all four thrusts in
      ``[0, T_max]`` given ``c`` and ``D`` (it always contains 0).

   Why the collective comes first (a Monte Carlo finding, docs/notes/robustness.md): the old
   priority (roll/pitch first, ``M ≤ T_max/2``, then the collective shifted
   into ``[M, T_max - M]``) cuts the collective to ``T_max/2`` per rotor whenever
   roll/pitch saturate.  With a thrust-to-weight ratio of 2 that is the hover
   thrust of the *nominal* mass, below the weight of a heavier vehicle and
   below ``m g / cos(tilt)`` at any tilt, so a saturated attitude loop lost
   altitude.

   The result satisfies the limits exactly, so the commanded rotor speeds are
   ``ω_i = sqrt(T_i / b)``.  Below saturation it is the exact inverse of the
   mixer (tested against :func:`nniquad.model.numeric.mixer_function`).

Attitude bandwidth against motor lag
------------------------------------
Linearised at hover, one attitude axis with the rate loop ``τ = J k_r (k e - p)``
and a first-order motor lag ``τ_m`` has the characteristic polynomial
``τ_m s³ + s² + k_r s + k_r k`` (the torque scale ``s`` and an inertia error
multiply ``k_r`` and ``k_r k`` alike and drop out of the Routh condition).
Routh: stable iff ``k τ_m < 1``, i.e. ``ω_a τ_m < 2 ζ_a``.  The loop therefore
tolerates a motor time constant up to ``2 ζ_a / ω_a``; a design that must
survive a motor ``f`` times slower than nominal with a gain margin ``GM``
(a factor on ``τ_m``) needs ``ω_a ≤ 2 ζ_a / (GM f τ_m)``
(:func:`attitude_wn_limit`).  Beyond the Routh limit the loop does not diverge
but falls into a limit cycle on the rotor limits, in which the lagged rotor
speeds average to about ``sqrt(c/2b)`` and the thrust ``b ω²`` drops to half the
allocated collective: the vehicle falls ("altitude lost").
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca

from nniquad.errors import SimulationError
from nniquad.model.layout import PARAM_NAMES
from nniquad.model.numeric import allocation_function

__all__ = [
    "altitude_command",
    "limit_norm",
    "tilt_setpoints",
    "attitude_torques",
    "sqrt_shaping",
    "allocate",
    "attitude_motor_lag_limit",
    "attitude_lag_s",
    "feedforward_lead_s",
    "attitude_wn_limit",
    "G_Z_MIN_FRACTION",
    "vertical_specific_force",
    "collective_thrust",
    "ATTITUDE_RESERVE_FRACTION",
    "TILT_COMPENSATION_MIN_COS",
]

#: Lower clamp of ``g - a_z`` as a fraction of g (thrust never commanded below 20 % of hover).
G_Z_MIN_FRACTION = 0.2
#: The tilt compensation ``1/(cos φ cos θ)`` is capped at 2 (60°).
TILT_COMPENSATION_MIN_COS = 0.5
#: Roll/pitch authority the allocation keeps even at a collective near a rotor limit,
#: as a fraction of the largest pair difference ``T_max/2`` (module docstring, 4a).
ATTITUDE_RESERVE_FRACTION = 0.25


def attitude_motor_lag_limit(wn: float, zeta: float) -> float:
    """Largest motor time constant [s] the linearised attitude loop tolerates: ``2 ζ_a / ω_a``.

    Routh condition of ``τ_m s³ + s² + k_r s + k_r k`` with ``k_r = 2 ζ_a ω_a``,
    ``k = ω_a / (2 ζ_a)`` (module docstring).
    """
    if not (wn > 0 and zeta > 0):
        raise SimulationError(f"attitude natural frequency and damping must be positive, got {wn!r}, {zeta!r}")
    return 2.0 * zeta / wn


def attitude_lag_s(wn: float, zeta: float) -> float:
    """The roll/pitch loop's lag ``2 ζ_a / ω_a`` [s]: the delay of ``ω_a² / (s² + 2 ζ_a ω_a s + ω_a²)`` at low
    frequency (its phase is ``-2 ζ_a ω / ω_a``), the same number as :func:`attitude_motor_lag_limit`."""
    return attitude_motor_lag_limit(wn, zeta)


def feedforward_lead_s(wn: float, zeta: float, rate_hz: float) -> float:
    """How far ahead to read an acceleration feedforward [s]: the attitude loop's lag (:func:`attitude_lag_s`)
    and half a sample period of the zero-order hold at ``rate_hz``."""
    return attitude_lag_s(wn, zeta) + 0.5 / rate_hz


def attitude_wn_limit(tau_motor_s: float, zeta: float, tau_factor: float = 2.0, gain_margin: float = 2.0) -> float:
    """Largest attitude natural frequency [rad/s] that keeps ``gain_margin`` on a motor ``tau_factor`` times slower.

    ``ω_a ≤ 2 ζ_a / (gain_margin · tau_factor · τ_m)``: with it the loop stays
    stable up to a motor time constant ``gain_margin · tau_factor · τ_m``.
    The defaults (factor 2, the top of the Monte Carlo range of
    :data:`nniquad.config.TAU_MOTOR_FACTOR_RANGE`; a gain margin of 2, i.e. 6 dB)
    give ``ω_a ≤ ζ_a / (2 τ_m)``: 28 rad/s for ζ_a = 1.13 and the paper's 20 ms motor.
    """
    for name, v in (("motor time constant", tau_motor_s), ("damping", zeta), ("tau factor", tau_factor),
                    ("gain margin", gain_margin)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise SimulationError(f"{name} must be a positive number, got {v!r}")
    return 2.0 * zeta / (gain_margin * tau_factor * tau_motor_s)




def altitude_command(z: ca.SX, z_dot: ca.SX, z_int: ca.SX, wn: ca.SX) -> ca.SX:
    """Vertical acceleration command (NED, down positive) of the altitude PID, reference 0.

    Closed-loop characteristic polynomial ``(s + ω_z)^3`` for a double integrator.
    """
    return -(3 * wn**2) * z - (3 * wn) * z_dot - wn**3 * z_int


def vertical_specific_force(g: Any, a_z: Any) -> Any:
    """The vertical specific force the thrust must give, ``g_z = max(g - a_z, G_Z_MIN_FRACTION g)`` [m/s²].

    ``a_z`` is the altitude loop's vertical acceleration command (NED, positive
    down); the clamp keeps the thrust above :data:`G_Z_MIN_FRACTION` of hover, so
    the tilt limit ``g_z tan(T_lim)`` and the setpoints stay defined.  Numbers in,
    a number out; CasADi symbols in, a symbol out.
    """
    return ca.fmax(g - a_z, G_Z_MIN_FRACTION * g)


def collective_thrust(m_nom: Any, g_z: Any, cos_tilt: Any) -> Any:
    """The collective thrust ``m̂ g_z / max(cos φ cos θ, TILT_COMPENSATION_MIN_COS)`` [N] (module docstring, item 2).

    The hover thrust of the vertical specific force ``g_z`` (:func:`vertical_specific_force`), compensated for
    the measured tilt ``cos φ cos θ`` and capped at 1/:data:`TILT_COMPENSATION_MIN_COS`.  Numbers in, a number
    out; CasADi symbols in, a symbol out.
    """
    return m_nom * g_z / ca.fmax(cos_tilt, TILT_COMPENSATION_MIN_COS)


def limit_norm(a: ca.SX, limit: ca.SX) -> ca.SX:
    """Scale the vector ``a`` down to norm ``limit`` if longer (direction kept, no division by zero)."""
    norm = ca.sqrt(ca.sumsqr(a))
    return a * (limit / ca.fmax(norm, limit))


def tilt_setpoints(a_h: ca.SX, g_z: ca.SX, psi: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """Roll and pitch setpoints that realise a horizontal acceleration, and the commanded tilt.

    With ``R = Rz(ψ) Ry(θ) Rx(φ)`` the thrust direction is ``-R e3`` and
    ``ξ'' = g e3 - (u1/m) R e3``.  For a desired specific force
    ``f = (a_x, a_y, -g_z)``, rotate its horizontal part into the yaw frame,
    ``b = Rz(-ψ) a_h``.  Then ``Ry(θ) Rx(φ) e3 = (cos φ sin θ, -sin φ, cos φ cos θ)``
    must be parallel to ``-(b_x, b_y, -g_z)``, which gives
    ``tan θ = -b_x / g_z`` and ``tan φ = b_y cos θ / g_z``, and
    ``cos φ cos θ = g_z / ‖f‖``, i.e. a tilt ``atan(‖a_h‖ / g_z)``.

    Returns
    -------
    phi_d, theta_d, tilt_cmd : SX
        Setpoints [rad] and the commanded tilt [rad].
    """
    c, s = ca.cos(psi), ca.sin(psi)
    bx = c * a_h[0] + s * a_h[1]
    by = -s * a_h[0] + c * a_h[1]
    theta_d = ca.atan2(-bx, g_z)
    phi_d = ca.atan(by * ca.cos(theta_d) / g_z)
    tilt = ca.atan(ca.sqrt(ca.sumsqr(a_h)) / g_z)
    return phi_d, theta_d, tilt


def sqrt_shaping(e: ca.SX, k: ca.SX, alpha: ca.SX) -> ca.SX:
    """Rate demand for the angle error ``e``: ``k e`` near zero, ``sqrt(2 α |e|)``-like beyond.

    ``k e`` for ``|e| <= α/k²``, else ``sign(e) sqrt(2 α (|e| - α/(2 k²)))``: the
    two pieces and their slopes agree at the switch (value ``α/k``, slope ``k``).
    """
    lin = alpha / k**2
    ae = ca.fabs(e)
    beyond = ca.sign(e) * ca.sqrt(2 * alpha * ca.fmax(ae - lin / 2, lin / 2))
    return ca.if_else(ae <= lin, k * e, beyond)


def attitude_torques(
    eta: ca.SX,
    rates_body: ca.SX,
    phi_d: ca.SX,
    theta_d: ca.SX,
    J_nom: ca.SX,
    wn_att: ca.SX,
    zeta_att: ca.SX,
    wn_yaw: ca.SX,
    zeta_yaw: ca.SX,
    scale: ca.SX,
    accel_limit: ca.SX,
) -> ca.SX:
    """Body torques ``(τ_φ, τ_θ, τ_ψ)`` [N m] of the attitude PD and the yaw hold at ψ = 0.

    ``rates_body`` are the gyro's body rates ``(p, q, r)``; ``J_nom`` the
    controller's inertia estimate ``(Ĵx, Ĵy, Ĵz)``.  Roll and pitch errors go
    through :func:`sqrt_shaping` with deceleration ``accel_limit``.
    """
    e_phi = phi_d - eta[0]
    e_theta = theta_d - eta[1]
    e_psi = -eta[2]
    k_rate = 2 * zeta_att * wn_att
    k_angle = wn_att / (2 * zeta_att)
    return scale * ca.vertcat(
        J_nom[0] * k_rate * (sqrt_shaping(e_phi, k_angle, accel_limit) - rates_body[0]),
        J_nom[1] * k_rate * (sqrt_shaping(e_theta, k_angle, accel_limit) - rates_body[1]),
        J_nom[2] * (wn_yaw**2 * e_psi - 2 * zeta_yaw * wn_yaw * rates_body[2]),
    )


def allocate(u1: ca.SX, tau: ca.SX, p: ca.SX, omega_max: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Rotor speeds [rad/s] for a thrust/torque demand, with the saturation priority of the module docstring.

    Parameters
    ----------
    u1
        Collective thrust demand [N].
    tau
        Torque demand ``(τ_φ, τ_θ, τ_ψ)`` [N m].
    p
        The vehicle parameters the controller assumes, in the order of
        :data:`nniquad.model.layout.PARAM_NAMES` (arm, thrust and drag coefficients, frame).
    omega_max
        Rotor-speed limit [rad/s].

    Returns
    -------
    w : SX (4,)
        Commanded rotor speeds in ``[0, ω_max]``.
    T : SX (4,)
        The allocated rotor thrusts ``b w²`` [N].
    """
    p = p if isinstance(p, (ca.SX, ca.DM)) else ca.DM([float(v) for v in p])
    b = p[PARAM_NAMES.index("b")]
    B = allocation_function()(p)
    t_max = b * omega_max**2
    c = u1 / 4
    D = ca.mtimes(B[:, 1:3], tau[0:2])
    Y = B[:, 3]
    # a. roll/pitch scaled together to fit around the demanded collective (it holds the
    #    altitude), keeping at least the reserved authority M_res near a rotor limit
    c = ca.fmin(ca.fmax(c, 0), t_max)
    allowed = ca.fmin(ca.fmax(ca.fmin(c, t_max - c), ATTITUDE_RESERVE_FRACTION * t_max / 2), t_max / 2)
    big = ca.mmax(ca.fabs(D))
    k = allowed / ca.fmax(big, allowed)
    D = D * k
    M = big * k
    # b. the collective moves only where the reserve needs it (within M_res of a limit)
    c = ca.fmin(ca.fmax(c, M), t_max - M)
    # c. yaw torque clipped to what keeps every rotor in [0, T_max]: T_i = c + D_i + Y_i τ_ψ
    ends_a, ends_b = (-c - D) / Y, (t_max - c - D) / Y
    y_lo = ca.mmax(ca.fmin(ends_a, ends_b))
    y_hi = ca.mmin(ca.fmax(ends_a, ends_b))
    tau_psi = ca.fmin(ca.fmax(tau[2], y_lo), y_hi)
    T = c + D + Y * tau_psi
    T = ca.fmin(ca.fmax(T, 0), t_max)  # rounding only
    return ca.sqrt(T / b), T
