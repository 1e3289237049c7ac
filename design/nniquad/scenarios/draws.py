"""Monte Carlo scenarios: the seeded draw of each scenario from the ranges and the study setup.

The ranges are in :mod:`nniquad.scenarios.ranges`, what the scenarios of one design share in
:mod:`nniquad.scenarios.setup`; their names are importable from here too.  See :mod:`nniquad.study`
for the ranges and why they were chosen, and for the reproducibility rule: scenario ``i`` of seed
``S`` comes from its own stream.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from nniquad.control.references import Reference
from nniquad.errors import MonteCarloError
from nniquad.laws.base import wind_equilibrium_m
from nniquad.scenarios.ranges import (
    BOX_KEYS,
    DEFAULT_RANGES,
    ScenarioRanges,
    certificate_rate_hz,
    positive_number_or_none,
    within_certificate_ranges,
)
from nniquad.scenarios.setup import DEFAULT_HORIZON_S, StudySetup, study_setup_from
from nniquad.sim import SimParams

__all__ = [
    "ScenarioRanges",
    "DEFAULT_RANGES",
    "StudySetup",
    "Scenario",
    "study_setup_from",
    "draw_scenario",
    "draw_scenarios",
    "DEFAULT_HORIZON_S",
    "certificate_rate_hz",
    "within_certificate_ranges",
    "BOX_KEYS",
]


@dataclass(frozen=True)
class Scenario:
    """One perturbed run: everything :func:`run_scenarios` needs (picklable, a few hundred bytes).

    Attributes
    ----------
    index, study_seed
        The scenario is stream ``index`` of seed ``study_seed`` (rerun it with
        ``--seed study_seed --rerun index``).
    params
        The perturbed :class:`nniquad.sim.SimParams` vector.
    xi0_m
        Initial horizontal position [m], at rest.
    noise_sigma_m, noise_rate_hz, noise_seed
        Position noise and the seed of its sequence.
    horizon_s, dt_s, output_dt_s
        Timing [s].
    band_m, xi0_nominal_norm_m
        Settling band radius [m] and the distance it is 2 % of.
    altitude_limit_m
        Altitude deviation counted as divergence [m].
    factors
        The drawn factors (mass, inertia per axis, attitude gain), for the report.
    controller
        Horizontal law (the layout of :attr:`params`).
    controller_sampling
        ``"discrete"`` or ``"held"`` (:attr:`StudySetup.controller_sampling`).
    reference, feedforward, feedforward_lead_s
        The reference followed and its feedforward (:attr:`StudySetup.reference`); with a reference
        :attr:`xi0_m` is the displacement from its start.
    delay_samples
        Measurement delay [samples] (:attr:`ScenarioRanges.delay_samples`).
    """

    index: int
    study_seed: int
    params: tuple[float, ...]
    xi0_m: tuple[float, float]
    noise_sigma_m: float
    noise_rate_hz: float
    noise_seed: int
    horizon_s: float
    dt_s: float
    output_dt_s: float
    band_m: float
    altitude_limit_m: float
    factors: tuple[tuple[str, float], ...] = ()
    controller: str = "nni"
    controller_sampling: str = "held"
    reference: Reference | None = None
    feedforward: bool = False
    feedforward_lead_s: float = 0.0
    delay_samples: int = 0

    @property
    def sim_params(self) -> SimParams:
        """:attr:`params` as a :class:`nniquad.sim.SimParams`."""
        return SimParams.from_vector(self.params, self.controller)

    def with_params(self, **changes: Any) -> "Scenario":
        """Copy with some parameters changed, by group (e.g. ``plant={"m": 3.0}`` for a vehicle that cannot hover).

        Keywords as :meth:`nniquad.sim.SimParams.with_`.
        """
        return replace(self, params=tuple(float(v) for v in self.sim_params.with_(**changes).vector()))

    def equilibrium_m(self) -> tuple[float, float]:
        """Static equilibrium under the constant wind (:func:`nniquad.laws.base.wind_equilibrium_m`)."""

        p = self.sim_params
        return wind_equilibrium_m(p.gains, p.nominal.m, (p.run.wind_x, p.run.wind_y))

    def describe(self) -> dict[str, Any]:
        """The drawn quantities with units (JSON ready)."""
        sp = self.sim_params
        p, w = sp.plant, sp.run
        wind = math.hypot(w.wind_x, w.wind_y)
        return {
            "mass_kg": p.m,
            **{f"{k}_factor": v for k, v in self.factors},
            "Jx_kg_m2": p.Jx, "Jy_kg_m2": p.Jy, "Jz_kg_m2": p.Jz,
            "attitude_gain": sp.inner.attitude_gain_scale,
            "tau_motor_s": p.tau_motor,
            "thrust_to_weight": 4 * p.b * p.omega_max**2 / (p.m * p.g),
            "noise_sigma_m": self.noise_sigma_m,
            "wind_N": [w.wind_x, w.wind_y],
            "wind_magnitude_N": wind,
            "wind_fraction_of_weight": wind / (sp.nominal.m * sp.nominal.g),
            "wind_direction_deg": math.degrees(math.atan2(w.wind_y, w.wind_x)) % 360.0 if wind > 0 else 0.0,
            "xi0_m": list(self.xi0_m),
            "displacement_m": math.hypot(*self.xi0_m),
        }


def _stream(seed: int, index: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))


def _check_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise MonteCarloError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def draw_scenario(index: int, seed: int, ranges: ScenarioRanges, setup: StudySetup) -> Scenario:
    """Scenario ``index`` of seed ``seed``: independent of how many others are drawn.

    Draw order from the scenario's stream: mass factor, inertia factors (x, y,
    z), attitude-gain factor, motor time constant, noise σ, wind magnitude,
    wind direction, displacement radius (``R √u``, uniform over the disk; with a rim fraction ``f``,
    ``R √min(1, u / (1 - f))``: the same draw puts a fraction ``f`` on the rim, the rest uniform),
    displacement direction, noise seed.
    """
    seed = _check_seed(seed)
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
        raise MonteCarloError(f"scenario index must be a non-negative integer, got {index!r}")
    base = setup.base
    tau_range = (ranges.tau_motor_s if ranges.tau_motor_s is not None
                 else tuple(base.plant.tau_motor * f for f in ranges.tau_motor_factor))
    if 2 * setup.dt_s > tau_range[0] + 1e-15:
        raise MonteCarloError(f"motor time constant must be at least 2 dt = {2 * setup.dt_s:g} s for RK4")
    rng = _stream(seed, int(index))
    u = lambda r: float(rng.uniform(r[0], r[1]))  # noqa: E731
    f_m = u(ranges.mass_factor)
    f_J = [u(ranges.inertia_factor) for _ in range(3)]
    f_att = u(ranges.attitude_gain_factor)
    tau = u(tau_range)  # the same stream position for a factor or an absolute range
    sigma = u(ranges.noise_sigma_m)
    weight = base.nominal.m * base.nominal.g
    wind = u(ranges.wind_N if ranges.wind_N is not None
             else tuple(weight * f for f in ranges.wind_weight_fraction))  # same stream position either way
    wdir = float(rng.uniform(0.0, 2 * math.pi))
    radius = setup.region_m * math.sqrt(min(1.0, float(rng.uniform(0.0, 1.0)) / (1.0 - ranges.rim_fraction)))
    rdir = float(rng.uniform(0.0, 2 * math.pi))
    noise_seed = int(rng.integers(0, 2**63 - 1))
    plant = base.plant
    Jx, Jy = plant.Jx * f_J[0], plant.Jy * f_J[1]
    Jz = min(plant.Jz * f_J[2], Jx + Jy)
    params = base.with_(
        plant={"m": plant.m * f_m, "Jx": Jx, "Jy": Jy, "Jz": Jz, "tau_motor": tau},
        inner={"attitude_gain_scale": base.inner.attitude_gain_scale * f_att},
        run={"motor_lag": 1.0, "wind_x": wind * math.cos(wdir), "wind_y": wind * math.sin(wdir),
             "sample_hold": 1.0, "dt": setup.dt_s,
             "discrete": 1.0 if setup.controller_sampling == "discrete" else 0.0,
             "sample_period": 1.0 / ranges.noise_rate_hz},
    )
    return Scenario(
        index=int(index), study_seed=seed, params=tuple(float(v) for v in params.vector()),
        xi0_m=(radius * math.cos(rdir), radius * math.sin(rdir)),
        noise_sigma_m=sigma, noise_rate_hz=ranges.noise_rate_hz, noise_seed=noise_seed,
        horizon_s=setup.horizon_s, dt_s=setup.dt_s, output_dt_s=setup.output_dt_s,
        band_m=setup.band_m, altitude_limit_m=ranges.altitude_limit_m,
        factors=(("mass", f_m), ("Jx", f_J[0]), ("Jy", f_J[1]), ("Jz", f_J[2]), ("attitude_gain", f_att)),
        controller=setup.controller, controller_sampling=setup.controller_sampling,
        reference=setup.reference, feedforward=setup.feedforward, feedforward_lead_s=setup.feedforward_lead_s,
        delay_samples=ranges.delay_samples,
    )


def draw_scenarios(n: int, seed: int, ranges: ScenarioRanges = DEFAULT_RANGES,
                   setup: StudySetup | None = None, *, horizon_s: float | None = None) -> list[Scenario]:
    """Scenarios ``0`` to ``n - 1`` of seed ``seed`` of a study (:func:`nniquad.study.study_setup` makes the setup of a
    certificate).

    Parameters
    ----------
    n
        Number of scenarios.
    seed
        The study's seed.
    ranges
        What may vary.
    setup
        What every scenario shares.
    horizon_s
        Replaces the setup's horizon when given [s].

    Raises
    ------
    MonteCarloError
        ``n <= 0``, a negative or non-integer seed, no setup.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n <= 0:
        raise MonteCarloError(f"number of samples must be a positive integer, got {n!r}")
    if not isinstance(setup, StudySetup):
        raise MonteCarloError("a StudySetup is required (nniquad.study.study_setup(certificate) makes one)")
    if horizon_s is not None and horizon_s != setup.horizon_s:
        h = positive_number_or_none(horizon_s)
        if h is None:
            raise MonteCarloError(f"horizon must be a positive number of seconds, got {horizon_s!r}")
        setup = replace(setup, horizon_s=h)
    return [draw_scenario(i, seed, ranges, setup) for i in range(int(n))]

