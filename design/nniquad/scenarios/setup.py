"""What every scenario of a study shares: the nominal parameter vector, start, band and horizon of one design.

From a vehicle and a gain set (:func:`study_setup_from`); :func:`nniquad.study.study_setup` reads a certificate into one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from nniquad.config import BAND_FRACTION, DT_S, OUTPUT_DT_S, TILT_LIMIT_DEG, XI0_M
from nniquad.control.references import Reference
from nniquad.errors import MonteCarloError
from nniquad.scenarios.ranges import DEFAULT_RANGES, ScenarioRanges, positive_number_or_none
from nniquad.sim import SimOptions, SimParams, to_gains
from nniquad.sim.options import check_rate_hz
from nniquad.sim.step_check import check_step

__all__ = ["StudySetup", "study_setup_from", "DEFAULT_HORIZON_S", "check_study_step", "RANGE_HINTS"]

#: Default simulated time of a scenario [s].
DEFAULT_HORIZON_S = 20.0


@dataclass(frozen=True)
class StudySetup:
    """What every scenario of a study shares, taken from the certificate.

    Attributes
    ----------
    base_params
        Nominal :class:`nniquad.sim.SimParams` vector (certificate vehicle,
        gains, inner loops, tilt limit; motor lag on; sampled measurement).
    xi0_nominal_m
        The certificate's initial position (sets the settling band).
    region_m
        Radius of the initial-displacement disk: ``min(certified region, cap)``.
    band_m
        Settling band radius [m] (2 % of ``‖xi0_nominal_m‖``).
    horizon_s, dt_s, output_dt_s
        Simulated time, RK4 step and output sample period [s].
    label
        Certificate identification (digest or name) for the report.
    controller
        Horizontal law of :attr:`base_params` (``"nni"``, ``"pd_velocity"``,
        ``"pd_filtered"``, ``"sni2"``: :data:`nniquad.sim.CONTROLLERS`); it fixes the layout
        of the parameter vector.
    controller_sampling
        ``"discrete"`` (the law in discrete time at the sample rate, what
        flies) or ``"held"`` (the controller integrated continuously on the held
        measurement): :attr:`nniquad.sim.SimOptions.controller_sampling`.
    reference, feedforward, feedforward_lead_s
        The reference every scenario follows (``None``: hold the origin) and its feedforward
        (:attr:`nniquad.sim.SimOptions.reference`, ...).  A scenario then starts on the reference with its
        velocity, displaced by its drawn displacement; it succeeds when the vehicle is not lost (settling does not
        apply) and its tracking error is recorded.
    """

    base_params: tuple[float, ...]
    xi0_nominal_m: tuple[float, float]
    region_m: float
    band_m: float
    horizon_s: float = DEFAULT_HORIZON_S
    dt_s: float = DT_S
    output_dt_s: float = OUTPUT_DT_S
    label: str = ""
    controller: str = "nni"
    controller_sampling: str = "held"
    reference: Reference | None = None
    feedforward: bool = False
    feedforward_lead_s: float = 0.0

    @property
    def base(self) -> SimParams:
        """:attr:`base_params` as a :class:`nniquad.sim.SimParams` (the layout of the law :attr:`StudySetup.controller`)."""
        return SimParams.from_vector(self.base_params, self.controller)

    def to_json(self) -> dict[str, Any]:
        b = self.base
        return {
            "certificate": self.label,
            "controller": self.controller,
            "gains": b.gains.as_dict(),
            "nominal_mass_kg": b.nominal.m,
            "tilt_limit_deg": math.degrees(b.run.tilt_limit),
            "xi0_nominal_m": list(self.xi0_nominal_m),
            "displacement_radius_m": self.region_m,
            "settling_band_m": self.band_m,
            "horizon_s": self.horizon_s,
            "dt_s": self.dt_s,
            "output_dt_s": self.output_dt_s,
            "controller_sampling": self.controller_sampling,
            "rate_hz": 1.0 / b.run.sample_period,
            **({} if self.reference is None else {"reference": self.reference.to_json(),
                                                  "feedforward": self.feedforward,
                                                  "feedforward_lead_s": self.feedforward_lead_s}),
        }


def study_setup_from(vehicle: Any, gains: Any, *, inner: Any = None, tilt_limit_deg: float = TILT_LIMIT_DEG,
                     xi0_m: Sequence[float] = XI0_M, region_m: float | None = None,
                     ranges: ScenarioRanges = DEFAULT_RANGES, horizon_s: float = DEFAULT_HORIZON_S,
                     label: str = "", controller_sampling: str | None = None) -> StudySetup:
    """The shared part of a study from a vehicle, a gain set and inner-loop gains (no certificate).

    ``gains`` is any controller's gain block (:class:`~nniquad.laws.nni.Gains`,
    :class:`~nniquad.laws.pd_velocity.PDGains`, :class:`~nniquad.laws.pd_filtered.PDFilteredGains`)
    or a mapping / tuple of NNI gains; the block's type picks the law, so the PD
    comparison laws are studied on the same scenarios as the NNI law.

    Parameters
    ----------
    vehicle
        The nominal vehicle (:class:`nniquad.model.vehicle.Vehicle`).
    gains
        The horizontal law's gain block (see above).
    inner
        Inner-loop gains (default :data:`nniquad.control.inner_gains.DEFAULT_INNER_LOOP_GAINS`).
    tilt_limit_deg
        Tilt limit [deg].
    xi0_m
        The nominal initial position [m]; its norm sets the settling band (2 %).
    region_m
        Radius of the initial-displacement disk [m] (default ``‖xi0_m‖``), capped at
        ``ranges.max_displacement_m``.
    ranges
        The perturbation ranges (their noise rate and displacement cap are used here).
    horizon_s
        Simulated time per scenario [s].
    label
        Identification of the design for the report.
    controller_sampling
        ``"discrete"`` or ``"held"``; default ``"discrete"`` for every law (NNI, ``sni2`` and the PD laws: the
        discrete-time controller at ``ranges.noise_rate_hz``: what flies, and what the
        tuner ranks; the PD laws' discrete forms are in :mod:`nniquad.sim.models`).

    Returns
    -------
    StudySetup

    Raises
    ------
    MonteCarloError
        A non-positive horizon, a bad initial position, or a rate the discrete
        controller cannot run at (its period must be a whole number of RK4 steps).
    """
    h = positive_number_or_none(horizon_s)
    if h is None:
        raise MonteCarloError(f"horizon must be a positive number of seconds, got {horizon_s!r}")
    try:
        xi0 = tuple(float(v) for v in xi0_m)
        if len(xi0) != 2 or not all(math.isfinite(v) for v in xi0) or math.hypot(*xi0) <= 0:
            raise ValueError
    except (TypeError, ValueError):
        raise MonteCarloError(f"initial position xi0_m must be a non-zero pair of numbers, got {xi0_m!r}") from None
    block = to_gains(gains)
    sampling = controller_sampling or "discrete"
    if sampling not in ("discrete", "held"):
        raise MonteCarloError(f"controller sampling of a study must be 'discrete' or 'held', got {sampling!r}")
    if sampling == "discrete":

        check_rate_hz(ranges.noise_rate_hz, DT_S, option="rate", error=MonteCarloError)
    opts: dict[str, Any] = {"model": "full", "horizon_s": h, "motor_lag": True, "controller_sampling": sampling,
                            "noise_rate_hz": ranges.noise_rate_hz, "tilt_limit_deg": tilt_limit_deg}
    if inner is not None:
        opts["inner"] = inner
    options = SimOptions(**opts)
    base = SimParams.from_options(vehicle, block, options)
    region = positive_number_or_none(region_m)
    if region is None:
        region = math.hypot(*xi0)
    return StudySetup(
        base_params=tuple(float(v) for v in base.vector()),
        xi0_nominal_m=(xi0[0], xi0[1]),
        region_m=min(region, ranges.max_displacement_m),
        band_m=BAND_FRACTION * math.hypot(*xi0),
        horizon_s=h,
        dt_s=options.dt_s,
        output_dt_s=options.output_dt_s,
        label=label,
        controller=base.controller,
        controller_sampling=sampling,
    )


#: What to change when the fastest scenario is too fast for the step (the Python API's names).
RANGE_HINTS = {"attitude": "ScenarioRanges.attitude_gain_factor",
               "motor lag": "ScenarioRanges.tau_motor_factor or tau_motor_s"}


def check_study_step(setup: StudySetup, ranges: ScenarioRanges, *, hint: Mapping[str, str] | None = None) -> None:
    """Refuse ranges whose fastest scenario the RK4 step cannot integrate, before any scenario runs.

    The fastest plant the ranges can draw -- the strongest attitude gain, the
    fastest motor, motor lag on -- goes through the runner's own check
    (:func:`nniquad.sim.step_check.check_step`), which every scenario also meets.

    Parameters
    ----------
    setup, ranges
        The study.
    hint
        What to change, by pole name (default :data:`RANGE_HINTS`; the command names its options).

    Raises
    ------
    MonteCarloError
        A pole too fast for the step ``setup.dt_s``.
    """
    base = setup.base
    tau_lo = (ranges.tau_motor_s[0] if ranges.tau_motor_s is not None
              else base.plant.tau_motor * ranges.tau_motor_factor[0])
    fastest = base.with_(plant={"tau_motor": tau_lo}, run={"motor_lag": 1.0, "dt": setup.dt_s},
                         inner={"attitude_gain_scale": base.inner.attitude_gain_scale * ranges.attitude_gain_factor[1]})
    check_step(fastest, "full", hint=RANGE_HINTS if hint is None else hint, error=MonteCarloError)
