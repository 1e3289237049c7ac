"""The tuner's search coordinates: the box, the attitude limits, and the maps between coordinates and gains."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Sequence

import numpy as np

from nniquad import config
from nniquad.config import DT_S
from nniquad.control.gains import DEFAULT_INNER_LOOP_GAINS, ControllerGains, InnerLoopGains
from nniquad.control.inner_loops import attitude_wn_limit
from nniquad.model.vehicle import Vehicle
from nniquad.tuning.laws import GAMMA_DELTA_MIN, KP_RANGE, PD_ZETA_RANGE, U_RANGE, V_RANGE, law_of  # noqa: F401
from nniquad.tuning.tune_options import TuneOptions


# ----------------------------------------------------------------------------- coordinates

#: Number of search coordinates of each horizontal law's gains (the attitude loop adds 3).
LAW_DIMS: dict[str, int] = {"nni": 3, "pd_velocity": 2, "pd_filtered": 3, "sni2": 4}


def law_dims(controller: str) -> int:
    """Number of gain coordinates of ``controller`` (:data:`LAW_DIMS`)."""
    try:
        return LAW_DIMS[controller]
    except KeyError:
        raise ValueError(f"unknown controller {controller!r}") from None


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
      error); the quick reduced tuner ran to that edge (issue 14, item 9a), where
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


def search_box(options: TuneOptions, dt_s: float = DT_S, vehicle: Vehicle | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the search coordinates (see the module docstring).

    NNI law, ``paper`` class: kp in [0.5, kp_max] 1/s², u in [0, 4] (γ from γ_max down to
    γ_max e⁻⁴), Γδ in [0.05, Γδ_max] 1/s; ``cascade`` class: ``v = ln(m kp δ - 1)`` in
    :data:`nniquad.tuning.laws.V_RANGE` instead of ``u`` (:mod:`nniquad.tuning.laws`).
    PD laws (``options.controller``): kp in the same
    range, the damping ratio ``k_d/(2√k_p)`` of the loop on the double
    integrator in :data:`PD_ZETA_RANGE`, and for ``pd_filtered`` the filter time
    constant τ_f in [1/f_s, 1] s (``f_s`` = ``config.CONTROL_RATE_HZ``: a filter
    faster than the sample period only passes the sampling steps).  Then, with
    the attitude loop: ω_a in [10, 150] rad/s, ζ_a in [0.5, 1.5], α/α_avail in [0.1, 1].
    With a ``vehicle`` the upper ends are :func:`gain_limits` (what the vehicle's
    attitude loop, its tilt-limited acceleration and the controller's sample rate
    can realise: kp ≤ 113 1/s², Γδ ≤ 314 1/s for the paper's vehicle); without
    one, kp ≤ 2000 and Γδ ≤ min(2.5/dt, π × ``config.CONTROL_RATE_HZ``).

    Parameters
    ----------
    options
        The tuning options (the model and the law decide the dimension, the tilt limit the kp bound).
    dt_s
        RK4 step [s]; bounds the controller pole Γδ ≤ 2.5/dt.
    vehicle
        The vehicle whose realisable gains bound the box (:func:`gain_limits`), or ``None``.

    Raises
    ------
    VehicleError
        If no design can fly the vehicle (:func:`nniquad.tuning.feasibility.check_feasible`:
        thrust at the tilt limit, motor lag against the attitude bandwidth, wind
        against the tilt limit), naming the limit.
    """
    if vehicle is None:
        kp_max = KP_RANGE[1]
        gd_max = min(config.RK4_STEP_LIMIT / dt_s, math.pi * config.CONTROL_RATE_HZ)
    else:
        from nniquad.tuning.feasibility import check_feasible

        check_feasible(vehicle, options.tilt_limit_deg)  # one line naming the limit, before any search
        limits = gain_limits(vehicle, options.tilt_limit_deg, dt_s)
        kp_max, gd_max = limits["kp_max"], limits["gamma_delta_max"]
    law = options.controller
    lo, hi = law_of(law, options.law_class).box(kp_max, gd_max, config.CONTROL_RATE_HZ,
                                                config.RK4_STEP_LIMIT / dt_s)
    if options.dims > law_dims(law):
        lo += [math.log(ATTITUDE_WN_RANGE[0]), ATTITUDE_ZETA_RANGE[0], ATTITUDE_ALPHA_RANGE[0]]
        hi += [math.log(ATTITUDE_WN_RANGE[1]), ATTITUDE_ZETA_RANGE[1], ATTITUDE_ALPHA_RANGE[1]]
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
           tau_motor_s: float | None = None, controller: str = "nni",
           law_class: str | None = None) -> tuple[ControllerGains, InnerLoopGains]:
    """Search coordinates → gains (and inner-loop gains when ``q`` has the 3 attitude coordinates too).

    Parameters
    ----------
    q
        Search coordinates (the law's :data:`LAW_DIMS`, plus 3 with the attitude loop).
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
    controller
        Horizontal law: ``"nni"`` (:class:`Gains`), ``"pd_velocity"`` (:class:`PDGains`)
        or ``"pd_filtered"`` (:class:`PDFilteredGains`).
    law_class
        The law class whose coordinates ``q`` are in (:mod:`nniquad.tuning.laws`; ``None``:
        ``paper`` for the NNI law, none for a PD law).
    """
    law = law_of(controller, law_class)
    n = law.dims
    gains = law.decode(q, m, gamma_max)
    if len(q) > n:
        a = q[n:]
        wn = min(math.exp(a[0]), attitude_wn_cap(tau_motor_s, float(a[1])))
        inner = replace(inner, attitude_wn_rad_s=wn, attitude_zeta=float(a[1]),
                        attitude_accel_limit_rad_s2=float(a[2]) * alpha_avail)
    return gains, inner


def encode(gains: ControllerGains, m: float, gamma_max: float, inner: InnerLoopGains | None = None,
           alpha_avail: float = 1.0, law_class: str | None = None) -> np.ndarray:
    """Inverse of :func:`decode` (the law is the type of ``gains``, the coordinates those of ``law_class``).

    Parameters
    ----------
    gains
        The gain block (:class:`Gains`, :class:`PDGains` or :class:`PDFilteredGains`).
    m
        Nominal mass [kg].
    gamma_max
        Ceiling of the sector bound.
    inner
        Inner-loop gains (adds the 3 attitude coordinates), or ``None``.
    alpha_avail
        Attitude acceleration headroom [rad/s^2].
    law_class
        As in :func:`decode`.
    """
    q = law_of(type(gains).controller, law_class).encode(gains, m, gamma_max)
    if inner is not None:
        q += [math.log(inner.attitude_wn_rad_s), inner.attitude_zeta,
              inner.attitude_accel_limit_rad_s2 / alpha_avail]
    return np.array(q)


def warm_start_coordinates(vehicle: Vehicle, options: TuneOptions,
                           warm_starts: Sequence[tuple[ControllerGains, InnerLoopGains]],
                           alpha_avail: float) -> list[np.ndarray | None]:
    """The search coordinates of warm starts, mapped into the tuned law (``None``: no such design in it).

    A filtered PD seeds the NNI law through its image
    (:func:`nniquad.control.pd_equivalence.nni_from_filtered_pd`) and an NNI gain set seeds a
    filtered PD through the inverse map (when ``m kp δ > 1``); both seed the ``sni2`` law through
    the NNI law followed by a fast low-pass (:func:`nniquad.control.sni.sni2_from_nni` at the top of
    :data:`nniquad.tuning.laws.SNI2_ZETA_RANGE`); other laws seed only themselves.

    Parameters
    ----------
    vehicle, options
        What is tuned.
    warm_starts
        ``(gains, inner loops)`` pairs.
    alpha_avail
        The attitude acceleration headroom [rad/s²] (:func:`attitude_accel_headroom`).
    """
    from nniquad.control.gains import Gains, PDFilteredGains, SNI2Gains
    from nniquad.control.pd_equivalence import filtered_pd_from_nni, nni_from_filtered_pd
    from nniquad.control.sni import sni2_from_nni
    from nniquad.errors import GainError
    from nniquad.tuning.laws import SNI2_ZETA_RANGE

    out: list[np.ndarray | None] = []
    for g, inn in warm_starts:
        try:
            if options.controller in ("nni", "sni2") and isinstance(g, PDFilteredGains):
                g = nni_from_filtered_pd(g, vehicle.m)
            elif options.controller == "pd_filtered" and isinstance(g, Gains):
                g = filtered_pd_from_nni(g, vehicle.m)
            if options.controller == "sni2" and isinstance(g, Gains):
                g = SNI2Gains(*sni2_from_nni(g.kp, g.Gamma, g.delta, SNI2_ZETA_RANGE[1]))
            out.append(encode(g, vehicle.m, options.gamma_max, inn if options.dims > law_dims(options.controller)
                              else None, alpha_avail, options.law_class))
        except (ValueError, GainError):  # another law, or outside this class's coordinates
            out.append(None)
    return out
