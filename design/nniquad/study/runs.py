"""Running Monte Carlo scenarios: one :func:`nniquad.sim.simulate` call each, and its verdict.

The verdict is the project's one definition (:mod:`nniquad.sim.verdicts`:
:func:`~nniquad.sim.verdicts.blew_up_batch`,
:func:`~nniquad.sim.verdicts.altitude_lost_batch`,
:func:`~nniquad.sim.verdicts.failure_reason`), with the study's scale:
distances are measured from the **setpoint** (a run the wind holds at a
displaced equilibrium outside the band has not settled), the divergence scale
is ``max(‖ξ(0)‖, band)`` and the altitude limit is the ranges'
``altitude_limit_m``.  The settling about the scenario's wind equilibrium
(:meth:`nniquad.scenarios.draws.Scenario.equilibrium_m`), the measure of
earlier versions, stays in the record under a name that says so,
``settling_time_about_wind_equilibrium_s``; it decides nothing.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any, Mapping, Sequence

import numpy as np

from nniquad.errors import NniquadError
from nniquad.scenarios.draws import Scenario
from nniquad.sim import SimOptions, simulate
from nniquad.sim.metrics import (
    DEFAULT_BAND_FRACTION,
    hover_window_start_s,
    rms_after,
    rotor_limit_share,
    settling_time_batch,
    steady_offset_m,
    tilt_deg,
)
from nniquad.sim.verdicts import altitude_lost_batch, blew_up_batch, failure_reason

__all__ = ["ScenarioResult", "run_scenarios"]


@dataclass(frozen=True)
class ScenarioResult:
    """Outcome of one scenario.

    Attributes
    ----------
    index, study_seed
        Which scenario (rerun with ``--seed study_seed --rerun index``).
    success
        Settled to the setpoint and never diverged.
    failure
        ``None``, ``"diverged"``, ``"altitude lost"``, ``"not settled"`` or ``"error: ..."``.
    settling_s
        Settling time into the band around the setpoint [s]; ``None`` if not settled.
    peak_tilt_deg
        Largest total tilt [deg] (``None`` if non-finite).
    offset_m
        Distance of the wind equilibrium (the static position a law without
        integral action holds under the scenario's wind) from the setpoint [m].
    final_error_m
        Distance from the setpoint at the end of the run [m].
    max_altitude_dev_m
        Largest altitude deviation [m].
    scenario
        The drawn quantities (:meth:`Scenario.describe`).
    tracking_rms_m, tracking_max_m
        With a reference: RMS and maximum tracking error over the whole run [m]
        (:mod:`nniquad.sim.tracking`); ``None`` without one, or for a lost vehicle.
    settling_time_about_wind_equilibrium_s
        Settling time into the same band around the wind equilibrium instead of
        the setpoint [s] (the verdict of earlier versions, kept for comparison;
        it moves the goalpost with the wind); ``None`` if not settled there.
    steady_offset_m
        Mean distance from the setpoint over the run's last second [m]
        (:func:`nniquad.sim.metrics.steady_offset_m`).
    tilt_command_rms_deg
        RMS commanded tilt over the hover window [deg]
        (:func:`nniquad.sim.metrics.hover_window_start_s`); ``None`` without one.
    rotor_limit_share
        Share of the recorded samples with a rotor command at a limit
        (:func:`nniquad.sim.metrics.rotor_limit_share`).
    """

    index: int
    study_seed: int
    success: bool
    failure: str | None
    settling_s: float | None
    peak_tilt_deg: float | None
    offset_m: float
    final_error_m: float | None
    max_altitude_dev_m: float | None
    scenario: dict[str, Any] = field(default_factory=dict)
    tracking_rms_m: float | None = None
    tracking_max_m: float | None = None
    settling_time_about_wind_equilibrium_s: float | None = None
    steady_offset_m: float | None = None
    tilt_command_rms_deg: float | None = None
    rotor_limit_share: float | None = None

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None
        return d

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> "ScenarioResult":
        return cls(**{f.name: data.get(f.name) for f in fields(cls)})


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _run_one(s: Scenario) -> ScenarioResult:
    eq = s.equilibrium_m()
    desc = s.describe()
    follow: dict[str, Any] = {}
    if s.reference is not None:
        # on the reference with its velocity, displaced by the drawn displacement
        pos, vel, _ = s.reference.sample(0.0)
        follow = {"reference": s.reference, "feedforward": s.feedforward, "feedforward_lead_s": s.feedforward_lead_s,
                  "xi0": tuple(map(float, pos[0] + s.xi0_m)), "v0": tuple(map(float, vel[0]))}
    try:
        opts = SimOptions(**{"model": "full", "horizon_s": s.horizon_s, "dt_s": s.dt_s, "output_dt_s": s.output_dt_s,
                             "noise_sigma_m": s.noise_sigma_m, "noise_rate_hz": s.noise_rate_hz,
                             "controller_sampling": s.controller_sampling, "seed": s.noise_seed, "xi0": s.xi0_m,
                             "delay_samples": s.delay_samples, **follow})
        with np.errstate(all="ignore"):
            res = simulate(None, None, opts, params=[s.sim_params])
    except NniquadError as exc:
        return ScenarioResult(s.index, s.study_seed, False, f"error: {exc}", None, None,
                              math.hypot(*eq), None, None, desc)
    xy, z, tr = res.xy, res.z_ned, res[0]
    with np.errstate(all="ignore"):
        scale = max(math.hypot(*s.xi0_m), s.band_m)
        blew_up = bool(blew_up_batch(xy, scale_m=scale, z_batch=z)[0])
        lost = bool(altitude_lost_batch(z, s.altitude_limit_m)[0])
        alt = float(np.max(np.abs(z[0])))
        peak_tilt = float(np.max(tilt_deg(res.phi[0], res.theta[0])))
        final = float(np.hypot(*xy[0, -1]))
        offset = steady_offset_m(res.t, xy[0])
        share = rotor_limit_share(tr.rotor_commands, float(s.sim_params.plant.omega_max))
    # the same band about the setpoint (the verdict) and about the wind equilibrium (kept for comparison)
    settling, settling_eq = settling_time_batch(res.t, np.stack([xy[0], xy[0] - np.asarray(eq)]),
                                                DEFAULT_BAND_FRACTION, s.band_m / DEFAULT_BAND_FRACTION)
    # following a reference, settling does not apply: the scenario succeeds unless the vehicle is lost
    following = s.reference is not None
    failure = failure_reason(blew_up, lost, following or math.isfinite(settling))
    tracking = tr.tracking() if following and failure is None else None
    hover = None if following or blew_up or lost else hover_window_start_s(xy[0], _finite_or_none(settling))
    return ScenarioResult(
        index=s.index, study_seed=s.study_seed, success=failure is None, failure=failure,
        settling_s=None if failure is not None or following else settling,
        peak_tilt_deg=_finite_or_none(peak_tilt), offset_m=math.hypot(*eq),
        final_error_m=_finite_or_none(final), max_altitude_dev_m=_finite_or_none(alt), scenario=desc,
        tracking_rms_m=None if tracking is None else tracking.tracking_rms_m,
        tracking_max_m=None if tracking is None else tracking.tracking_max_m,
        settling_time_about_wind_equilibrium_s=None if blew_up or lost or following else _finite_or_none(settling_eq),
        steady_offset_m=None if following else _finite_or_none(offset),
        tilt_command_rms_deg=rms_after(res.t, tr.cmd_tilt_deg, hover),
        rotor_limit_share=_finite_or_none(share),
    )


def run_scenarios(batch: Sequence[Scenario]) -> list[ScenarioResult]:
    """Simulate a batch of scenarios (the unit of work of the executors).

    A pure function of the scenarios: the same scenario gives the same result
    in any process, batch or order.  Each scenario is one single-threaded
    :func:`nniquad.sim.simulate` call with its own noise sequence.
    Simulation errors become failures (``"error: ..."``), never exceptions.
    """
    return [_run_one(s) for s in batch]
