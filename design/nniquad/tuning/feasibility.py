"""Can this vehicle fly a design at all?  The checks made before any tuning starts.

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
  (:func:`nniquad.tuning.coordinates.attitude_wn_cap`) and the horizontal loop
  ``sqrt(kp)`` must stay ``config.CASCADE_BANDWIDTH_RATIO`` times below it
  (:func:`nniquad.tuning.coordinates.gain_limits`); when that leaves no kp
  in the search box, the motors are too slow for any horizontal loop;
* **wind against the tilt limit**: a constant horizontal force ``F`` is held
  only with ``m g tan T >= F``; the Monte Carlo wind range
  (``config.WIND_WEIGHT_FRACTION_RANGE``, a share of the weight) must stay below
  ``tan T``, or no design survives its own Monte Carlo study.
"""

from __future__ import annotations

import math

from nniquad import config
from nniquad.errors import VehicleError
from nniquad.model.vehicle import Vehicle

__all__ = ["feasibility_problems", "check_feasible"]


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
    from nniquad.tuning.coordinates import KP_RANGE, gain_limits

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
