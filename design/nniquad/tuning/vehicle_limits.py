"""What a vehicle allows a design: the largest gains it can realise, and whether it can fly one at all.

:func:`gain_limits` gives the upper ends of the tuner's box; :func:`attitude_wn_cap` and
:func:`attitude_accel_headroom` the attitude loop's.

A vehicle file of another scale may ask for what no gain set of this structure
can give.  Rather than searching for minutes and then reporting "no gain set
settled", :func:`check_feasible` refuses at once with one line naming the limit:

* **thrust at the tilt limit**: holding altitude at tilt ``T`` needs the
  collective ``m g / cos T``; four rotors give at most ``4 b ω_max²``, so the
  thrust-to-weight ratio must exceed ``1 / cos T`` (1.155 at 30°).  Below it the
  rotors saturate before the commanded tilt is reached and the altitude loop
  and the horizontal loop fight over the collective;
* **motor lag against the attitude bandwidth the horizontal loop needs**: the
  attitude loop is capped at the frequency its motors allow
  (:func:`attitude_wn_cap`) and the horizontal loop
  ``sqrt(kp)`` must stay ``config.CASCADE_BANDWIDTH_RATIO`` times below it
  (:func:`gain_limits`); when that leaves no kp
  in the search box, the motors are too slow for any horizontal loop;
* **wind against the tilt limit**: a constant horizontal force ``F`` is held
  only with ``m g tan T >= F``; the Monte Carlo wind range
  (``config.WIND_WEIGHT_FRACTION_RANGE``, a share of the weight) must stay below
  ``tan T``, or no design survives its own Monte Carlo study.
"""

from __future__ import annotations

import math

import numpy as np

from nniquad import config
from nniquad.config import DT_S
from nniquad.control.inner_loops import attitude_wn_limit
from nniquad.errors import VehicleError
from nniquad.laws.search_ranges import KP_RANGE
from nniquad.model.numeric import allocation_numpy
from nniquad.model.vehicle import Vehicle

__all__ = ["feasibility_problems", "check_feasible", "gain_limits", "attitude_wn_cap", "attitude_accel_headroom",
           "ATTITUDE_WN_RANGE", "ATTITUDE_ZETA_RANGE", "ATTITUDE_ALPHA_RANGE"]


#: Bounds of the attitude coordinates (``full``): ω_a [rad/s], ζ_a, α/α_avail.
ATTITUDE_WN_RANGE: tuple[float, float] = (10.0, 150.0)
ATTITUDE_ZETA_RANGE: tuple[float, float] = (0.5, 1.5)
ATTITUDE_ALPHA_RANGE: tuple[float, float] = (0.1, 1.0)


def gain_limits(vehicle: Vehicle, tilt_limit_deg: float = config.TILT_LIMIT_DEG, dt_s: float = DT_S,
                control_rate_hz: float = config.CONTROL_RATE_HZ) -> dict[str, float]:
    """The largest NNI gains a vehicle can realise: the upper ends of the search box.

    * ``kp`` (the horizontal loop ``ξ'' = -kp ξ + z/m`` runs at ``sqrt(kp)`` rad/s):

      - **attitude bandwidth**: the attitude loop realises the commanded tilt, so
        ``sqrt(kp)`` stays ``config.CASCADE_BANDWIDTH_RATIO`` (3) times below the
        fastest attitude natural frequency the tuner may choose,
        ``min(ATTITUDE_WN_RANGE[1], attitude_wn_cap(τ_m, ζ_max))`` (the motor-lag cap
        at the largest damping of the box);
      - **tilt-limited acceleration**: ``kp`` times the settling band
        (``BAND_FRACTION × ‖ξ0‖``, 5 cm) must not exceed ``g tan(tilt limit)``,
        so that the loop is linear inside the band it has to hold: a larger ``kp``
        commands the full tilt for a 5 cm error and holds the band as a bang-bang
        limit cycle of the tilt saturation, which no attitude loop follows.

      The old box went to kp = 2000 (``sqrt(kp)`` = 45 rad/s, full tilt for a 3 mm
      error); the quick reduced tuner ran to that edge (docs/notes/tuning.md), where
      the certified reach is 5 mm and the full model does not settle.
    * ``Γδ`` (the controller pole, 1/s): below the Nyquist frequency ``π f_s`` of the
      position sample rate ``config.CONTROL_RATE_HZ`` (a pole faster than half a sample
      period cannot be realised by the sampled controller), and inside the RK4
      step's stability region (``config.RK4_STEP_LIMIT / dt``).

    Parameters
    ----------
    vehicle
        The vehicle (motor time constant ``tau_motor``, ``g``).
    tilt_limit_deg
        Tilt limit [deg].
    dt_s
        RK4 step [s].
    control_rate_hz
        Position sample rate of the controller [Hz].

    Returns
    -------
    dict
        ``kp_max`` and ``gamma_delta_max`` (the bounds used) and the terms they are
        the smaller of: ``kp_max_attitude``, ``kp_max_band``, ``gamma_delta_max_sampling``,
        ``gamma_delta_max_rk4``; ``attitude_wn_max`` [rad/s].
    """
    wn_a = min(ATTITUDE_WN_RANGE[1], attitude_wn_cap(vehicle.tau_motor, ATTITUDE_ZETA_RANGE[1]))
    kp_att = (wn_a / config.CASCADE_BANDWIDTH_RATIO) ** 2
    a_max = vehicle.g * math.tan(math.radians(tilt_limit_deg))
    kp_band = a_max / (config.BAND_FRACTION * config.XI0_NORM_M)
    gd_sampling = math.pi * control_rate_hz
    gd_rk4 = config.RK4_STEP_LIMIT / dt_s
    return {"kp_max": min(KP_RANGE[1], kp_att, kp_band), "kp_max_attitude": kp_att, "kp_max_band": kp_band,
            "attitude_wn_max": wn_a, "gamma_delta_max": min(gd_sampling, gd_rk4),
            "gamma_delta_max_sampling": gd_sampling, "gamma_delta_max_rk4": gd_rk4}




def attitude_accel_headroom(vehicle: Vehicle, tilt_limit_deg: float) -> float:
    """Roll angular acceleration the rotors can still give at the tilt limit [rad/s²].

    Holding altitude at tilt ``T`` needs ``c = m g / (4 cos T)`` per rotor; a roll
    torque ``τ`` moves rotor ``i`` by ``B_i1 τ`` (the vehicle frame's allocation matrix,
    :func:`nniquad.model.numeric.allocation_numpy`) and no rotor may move by more than
    ``min(c, T_max - c)``, so ``α_avail = min(c, T_max - c) / (max_i |B_i1| J_x)``, the
    smaller of roll and pitch: ``2 l min(c, T_max - c) / J_x`` for '+', ``2√2 l`` for 'x'.

    Parameters
    ----------
    vehicle
        The vehicle (mass, arm, rotor limits, inertias).
    tilt_limit_deg
        Tilt limit [deg].
    """
    c = vehicle.m * vehicle.g / (4.0 * math.cos(math.radians(tilt_limit_deg)))
    t_max = vehicle.b * vehicle.omega_max**2
    per_torque = np.max(np.abs(allocation_numpy(vehicle)[:, 1:3]), axis=0)  # rotor thrust per roll, pitch torque
    return float(max(min(c, t_max - c), 0.0) / np.max(per_torque * np.array([vehicle.Jx, vehicle.Jy])))


def attitude_wn_cap(tau_motor_s: float | None, zeta: float) -> float:
    """Largest attitude natural frequency the tuner may choose [rad/s] (``inf`` without motor lag).

    :func:`nniquad.control.inner_loops.attitude_wn_limit` at the slowest motor of the
    Monte Carlo range (``config.TAU_MOTOR_FACTOR_RANGE[1]`` × nominal) with gain margin
    ``config.ATTITUDE_GAIN_MARGIN``.  Without it the sweep drove ω_a to ~100 rad/s, at the
    Routh limit ``2 ζ_a/τ_m`` of the *nominal* motor: every slower motor then put the
    attitude loop into a limit cycle on the rotor limits (docs/notes/robustness.md).

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


def feasibility_problems(vehicle: Vehicle, tilt_limit_deg: float = config.TILT_LIMIT_DEG,
                         wind_fraction_max: float = config.WIND_WEIGHT_FRACTION_RANGE[1]) -> list[str]:
    """The limits this vehicle violates, one line each (empty: nothing stands in the way of a design).

    Parameters
    ----------
    vehicle
        The vehicle.
    tilt_limit_deg
        Tilt limit [deg].
    wind_fraction_max
        Largest wind force of the Monte Carlo range as a share of the weight ``m g``.
    """
    problems = []
    tilt = math.radians(tilt_limit_deg)
    weight = vehicle.m * vehicle.g
    thrust_max = 4.0 * vehicle.b * vehicle.omega_max**2
    needed = weight / math.cos(tilt)
    if thrust_max <= needed:
        problems.append(
            f"thrust: thrust-to-weight {thrust_max / weight:.3g} is below 1/cos(tilt limit) = "
            f"{1 / math.cos(tilt):.3g}; hovering at the {tilt_limit_deg:g} deg tilt limit needs {needed:.4g} N, "
            f"the rotors give {thrust_max:.4g} N (raise omega_max or lower the tilt limit)")
    limits = gain_limits(vehicle, tilt_limit_deg)
    if limits["kp_max"] <= KP_RANGE[0]:
        problems.append(
            f"motor lag: tau_motor = {vehicle.tau_motor:g} s allows an attitude bandwidth of at most "
            f"{limits['attitude_wn_max']:.3g} rad/s, so the horizontal loop (sqrt(kp), "
            f"{config.CASCADE_BANDWIDTH_RATIO:g}x slower) gets kp <= {limits['kp_max']:.3g} 1/s^2, below the "
            f"smallest kp searched ({KP_RANGE[0]:g})")
    if wind_fraction_max >= math.tan(tilt):
        problems.append(
            f"wind: the Monte Carlo wind reaches {100 * wind_fraction_max:.3g} % of the weight, more than the "
            f"m g tan(tilt limit) = {100 * math.tan(tilt):.3g} % the tilt limit can hold against")
    return problems


def check_feasible(vehicle: Vehicle, tilt_limit_deg: float = config.TILT_LIMIT_DEG,
                   wind_fraction_max: float = config.WIND_WEIGHT_FRACTION_RANGE[1]) -> None:
    """Refuse a vehicle no design can fly (:func:`feasibility_problems`), with one line naming the limit.

    Parameters
    ----------
    vehicle
        The vehicle.
    tilt_limit_deg
        Tilt limit [deg].
    wind_fraction_max
        Largest Monte Carlo wind force as a share of the weight.

    Raises
    ------
    VehicleError
        Naming the first limit violated (and how many more there are).
    """
    problems = feasibility_problems(vehicle, tilt_limit_deg, wind_fraction_max)
    if problems:
        more = f" (and {len(problems) - 1} more limit(s))" if len(problems) > 1 else ""
        raise VehicleError(f"vehicle {vehicle.name!r} cannot fly a design: {problems[0]}{more}")
