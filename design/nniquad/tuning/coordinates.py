"""The tuner's search coordinates: the box, the attitude limits, and the maps between coordinates and gains.

Each law writes its own gain coordinates, box and maps (:meth:`nniquad.laws.base.ControlLaw.coordinates`,
``box``, ``decode``, ``encode``); :class:`TunableLaw` is a law in one law class, as the tuner searches it, and
this module adds the attitude loop's three coordinates (``full``) and the vehicle's limits.

=================  ==============================================  ==========================================
law / class        coordinates (before the attitude loop's 3)      what the box encodes
=================  ==============================================  ==========================================
``nni``/paper      ``ln kp``, ``u = ln(γ_max m kp δ)``, ``ln Γδ``  the sector bound is ``u >= 0``
``nni``/cascade    ``ln kp``, ``v = ln(m kp δ - 1)``, ``ln Γδ``    the Routh condition ``m kp δ > 1``
``sni2``/paper     ``ln kp``, ``u = ln(γ_max/γ)``, ``ln ω``,       the DC (sector) condition ``γ <= γ_max``
                   ``ln ζ``
``sni2``/cascade   ``ln kp``, ``v = ln(1/γ - 1)``, ``ln ω``,       ``γ < 1``
                   ``ln ζ``
``pd_velocity``    ``ln k_p``, ``ζ = k_d/(2√k_p)``                 -
``pd_filtered``    ``ln k_p``, ``ζ``, ``ln τ_f``                   with a class: the NNI image must lie in its box
=================  ==============================================  ==========================================

A filtered PD tuned "in a class" (``TuneOptions.law_class``) is the PD law
whose NNI image satisfies the class's bounds: :meth:`TunableLaw.image_violation`
says by how much it does not (0 inside), and the objective ranks a violation
above every admissible cost.  Its coordinates stay the PD ones, so its search is
the PD tuner's with the class added; the NNI tuner is then seeded with its image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from nniquad import config
from nniquad.config import DT_S
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.errors import GainError
from nniquad.laws.base import ControlLaw, GainBlock, TuningBox
from nniquad.laws.search_ranges import KP_RANGE
from nniquad.laws.registry import law_named
from nniquad.model.vehicle import Vehicle
from nniquad.tuning.tune_options import TuneOptions
from nniquad.tuning.vehicle_limits import (
    ATTITUDE_ALPHA_RANGE,
    ATTITUDE_WN_RANGE,
    ATTITUDE_ZETA_RANGE,
    attitude_wn_cap,
    check_feasible,
    gain_limits,
)

# ----------------------------------------------------------------------------- coordinates


@dataclass(frozen=True)
class TunableLaw:
    """A law in one law class, as the tuner searches it: its coordinates, box and maps (module docstring).

    Attributes
    ----------
    law
        The registered law.
    law_class
        ``"paper"``, ``"cascade"`` or ``None`` (a PD law without a class).
    """

    law: ControlLaw
    law_class: str | None

    @property
    def controller(self) -> str:
        """The law's name."""
        return self.law.name

    @property
    def coordinates(self) -> tuple[str, ...]:
        """Names of the gain coordinates, in order."""
        return self.law.coordinates(self.law_class)

    @property
    def dims(self) -> int:
        """Number of gain coordinates."""
        return len(self.coordinates)

    @property
    def sector_face(self) -> bool:
        """Whether the fastest designs sit on the face ``q1 = lo`` (the sector bound of the paper class); the
        initial design then puts a share of its points on that face (:func:`nniquad.tuning.search.initial_design`)."""
        return self.law.sector_face(self.law_class)

    def box(self, kp_max: float, gamma_delta_max: float, control_rate_hz: float,
            rk4_pole_max: float = math.inf) -> tuple[list[float], list[float]]:
        """Lower and upper ends of the gain coordinates.

        Parameters
        ----------
        kp_max
            Largest kp [1/s²] (:func:`gain_limits`).
        gamma_delta_max
            Largest controller pole [1/s].
        control_rate_hz
            The control rate [Hz].
        rk4_pole_max
            Largest pole the RK4 step integrates [1/s].
        """
        return self.law.box(self.law_class, TuningBox(kp_max, gamma_delta_max, control_rate_hz, rk4_pole_max))

    def decode(self, q: Sequence[float], m: float, gamma_max: float) -> GainBlock:
        """Gain coordinates -> gains (only the first :attr:`dims` entries of ``q`` are read).

        Parameters
        ----------
        q
            The coordinates.
        m
            Nominal mass [kg].
        gamma_max
            The sector bound's ceiling.
        """
        return self.law.decode(q, m, gamma_max, self.law_class)

    def encode(self, gains: GainBlock, m: float, gamma_max: float) -> list[float]:
        """Gains -> gain coordinates (inverse of :meth:`decode`).

        Parameters
        ----------
        gains
            A gain block of the law.
        m
            Nominal mass [kg].
        gamma_max
            The sector bound's ceiling.

        Raises
        ------
        ValueError
            A gain block of another law, or gains outside the class's coordinates.
        """
        return self.law.encode(gains, m, gamma_max, self.law_class)

    def image_violation(self, gains: GainBlock, m: float, gamma_max: float, kp_max: float,
                        gamma_delta_max: float) -> float:
        """How far a design tuned through its NNI image lies outside the class's box (0 inside; log units).

        Parameters
        ----------
        gains
            A gain block of the law.
        m
            Nominal mass [kg].
        gamma_max
            The sector bound's ceiling.
        kp_max, gamma_delta_max
            The box's upper ends of the NNI image.
        """
        return self.law.image_violation(gains, m, gamma_max, self.law_class, TuningBox(kp_max, gamma_delta_max, 1.0))


def tunable_law(controller: str, law_class: str | None = None) -> TunableLaw:
    """The law named ``controller`` in ``law_class`` (``None``: the law's default, ``paper`` for a law of the NI
    structure).

    Parameters
    ----------
    controller
        A registered law's name.
    law_class
        ``"paper"``, ``"cascade"`` or ``None``.

    Raises
    ------
    ValueError
        An unknown law, or a class the law has no coordinates for.
    """
    try:
        law = law_named(controller)
    except GainError as exc:
        raise ValueError(str(exc)) from None
    return TunableLaw(law, law.check_class(law_class))


def law_dims(controller: str) -> int:
    """Number of gain coordinates of ``controller`` (its default class's; every class of a law has as many).

    Parameters
    ----------
    controller
        A registered law's name.
    """
    return tunable_law(controller).dims


def search_box(options: TuneOptions, dt_s: float = DT_S, vehicle: Vehicle | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the search coordinates (see the module docstring).

    NNI law, ``paper`` class: kp in [0.5, kp_max] 1/s², u in [0, 4] (γ from γ_max down to
    γ_max e⁻⁴), Γδ in [0.05, Γδ_max] 1/s; ``cascade`` class: ``v = ln(m kp δ - 1)`` in
    :data:`nniquad.laws.search_ranges.V_RANGE` instead of ``u`` (each law's ``box``).
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
        If no design can fly the vehicle (:func:`nniquad.tuning.vehicle_limits.check_feasible`:
        thrust at the tilt limit, motor lag against the attitude bandwidth, wind
        against the tilt limit), naming the limit.
    """
    if vehicle is None:
        kp_max = KP_RANGE[1]
        gd_max = min(config.RK4_STEP_LIMIT / dt_s, math.pi * config.CONTROL_RATE_HZ)
    else:
        check_feasible(vehicle, options.tilt_limit_deg)  # one line naming the limit, before any search
        limits = gain_limits(vehicle, options.tilt_limit_deg, dt_s)
        kp_max, gd_max = limits["kp_max"], limits["gamma_delta_max"]
    law = tunable_law(options.controller, options.law_class)
    lo, hi = law.box(kp_max, gd_max, config.CONTROL_RATE_HZ, config.RK4_STEP_LIMIT / dt_s)
    if options.dims > law.dims:
        lo += [math.log(ATTITUDE_WN_RANGE[0]), ATTITUDE_ZETA_RANGE[0], ATTITUDE_ALPHA_RANGE[0]]
        hi += [math.log(ATTITUDE_WN_RANGE[1]), ATTITUDE_ZETA_RANGE[1], ATTITUDE_ALPHA_RANGE[1]]
    return np.array(lo), np.array(hi)


def decode(q: Sequence[float], m: float, gamma_max: float,
           inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS, alpha_avail: float = 1.0,
           tau_motor_s: float | None = None, controller: str = "nni",
           law_class: str | None = None) -> tuple[GainBlock, InnerLoopGains]:
    """Search coordinates → gains (and inner-loop gains when ``q`` has the 3 attitude coordinates too).

    Parameters
    ----------
    q
        Search coordinates (the law's :func:`law_dims`, plus 3 with the attitude loop).
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
        Horizontal law (a registered law's name).
    law_class
        The law class whose coordinates ``q`` are in (``None``: the law's default: ``paper`` for a law of the
        NI structure, none for a PD law).
    """
    law = tunable_law(controller, law_class)
    n = law.dims
    gains = law.decode(q, m, gamma_max)
    if len(q) > n:
        a = q[n:]
        wn = min(math.exp(a[0]), attitude_wn_cap(tau_motor_s, float(a[1])))
        inner = replace(inner, attitude_wn_rad_s=wn, attitude_zeta=float(a[1]),
                        attitude_accel_limit_rad_s2=float(a[2]) * alpha_avail)
    return gains, inner


def encode(gains: GainBlock, m: float, gamma_max: float, inner: InnerLoopGains | None = None,
           alpha_avail: float = 1.0, law_class: str | None = None) -> np.ndarray:
    """Inverse of :func:`decode` (the law is the type of ``gains``, the coordinates those of ``law_class``).

    Parameters
    ----------
    gains
        A gain block of any law.
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
    q = tunable_law(gains.law.name, law_class).encode(gains, m, gamma_max)
    if inner is not None:
        q += [math.log(inner.attitude_wn_rad_s), inner.attitude_zeta,
              inner.attitude_accel_limit_rad_s2 / alpha_avail]
    return np.array(q)


def warm_start_coordinates(vehicle: Vehicle, options: TuneOptions,
                           warm_starts: Sequence[tuple[GainBlock, InnerLoopGains]],
                           alpha_avail: float) -> list[np.ndarray | None]:
    """The search coordinates of warm starts, mapped into the tuned law (``None``: no such design in it).

    Each warm start goes through the tuned law's :meth:`~nniquad.laws.base.ControlLaw.seed_from`: a filtered PD
    seeds the NNI law through its image and an NNI gain set seeds a filtered PD through the inverse map (when
    ``m kp δ > 1``); both seed the ``sni2`` law through the NNI law followed by a fast low-pass; other laws seed
    only themselves.

    Parameters
    ----------
    vehicle, options
        What is tuned.
    warm_starts
        ``(gains, inner loops)`` pairs.
    alpha_avail
        The attitude acceleration headroom [rad/s²] (:func:`attitude_accel_headroom`).
    """
    law = tunable_law(options.controller, options.law_class)
    with_attitude = options.dims > law.dims
    out: list[np.ndarray | None] = []
    for g, inn in warm_starts:
        seed = law.law.seed_from(g, vehicle.m)
        try:
            out.append(None if seed is None else
                       encode(seed, vehicle.m, options.gamma_max, inn if with_attitude else None, alpha_avail,
                              options.law_class))
        except (ValueError, GainError):  # outside this class's coordinates
            out.append(None)
    return out
