"""The fixed scenario set of the robust objective: box corners, the nominal run and random interior draws.

Why a fixed set (common random numbers)
---------------------------------------
The robust cost of a candidate is a quantile of its settling times over perturbed
vehicles.  If every candidate saw its own random perturbations, two candidates
would differ by sampling noise as much as by their gains, and the search would
chase the noise.  So the set is drawn **once**, from
:attr:`nniquad.tuning.tune_options.TuneOptions.scenario_seed`, and every candidate
is simulated on the same plants, the same noise sequences, the same winds and
the same start points; only its gains and inner loops change
(:meth:`TuningScenario.params`).

What is in it
-------------
* the nominal run (paper start, no wind, no noise unless the options ask for
  it): the scenario of the nominal objective, reported as ``nominal_settling_s``;
* the corners of the box of the parameters that drive failures (docs/notes/robustness.md):
  mass factor lo/hi × motor time-constant factor lo/hi × attitude-gain factor
  lo/hi, each with the noise σ at its maximum, the wind at its maximum pushing
  along the start displacement (against the return), the start at the
  displacement radius (the corner in which the vehicle needs the most
  tilt to get going), nominal inertia;
* :data:`N_RANDOM` interior draws of the Monte Carlo generator
  (:func:`nniquad.scenarios.draws.draw_scenario`, stream ``i`` of the tuning seed):
  every Monte Carlo quantity (inertias, wind direction, start point, noise) uniform.

The ranges are the Monte Carlo defaults (:data:`nniquad.scenarios.draws.DEFAULT_RANGES`)
unless given.  The benchmark Monte Carlo study of a tuned design must use a seed
other than the tuning seed (default :data:`nniquad.config.TUNING_SCENARIO_SEED`),
or it measures the design on scenarios it was tuned on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nniquad.config import CONTROL_RATE_HZ, XI0_M
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.laws.base import GainBlock, wind_equilibrium_m
from nniquad.laws.nni import PAPER_GAINS
from nniquad.model.vehicle import Vehicle
from nniquad.scenarios.draws import DEFAULT_RANGES, draw_scenario, study_setup_from
from nniquad.sim import SimOptions, SimParams

__all__ = ["N_RANDOM", "TuningScenario", "tuning_scenarios", "displacement_radius_m"]

#: Random interior draws of the tuning set (8 corners + nominal + these = 20 scenarios).
N_RANDOM = 11


@dataclass(frozen=True)
class TuningScenario:
    """One perturbed vehicle of the tuning set; the candidate's gains are applied by :meth:`params`.

    Attributes
    ----------
    label
        ``"nominal"``, ``"corner m+ tau- att+"``-style, or ``"random 3"``.
    mass_factor, inertia_factors, attitude_gain_factor
        Factors on the nominal mass, inertias (x, y, z) and attitude-loop torques.
    tau_motor_s
        Motor time constant [s].
    noise_sigma_m, noise_seed
        Position noise σ [m] (sampled at the control rate) and the seed of its sequence.
    wind_N
        Constant horizontal wind force (north, east) [N].
    xi0_m
        Start position [m], at rest.
    """

    label: str
    mass_factor: float
    inertia_factors: tuple[float, float, float]
    attitude_gain_factor: float
    tau_motor_s: float
    noise_sigma_m: float
    noise_seed: int
    wind_N: tuple[float, float]
    xi0_m: tuple[float, float]
    nominal: bool = False
    extra: dict[str, Any] = field(default_factory=dict, compare=False)

    def options(self, horizon_s: float, tilt_limit_deg: float, inner: InnerLoopGains, *,
                motor_lag: bool = True, output_dt_s: float = 0.005, rate_hz: float = CONTROL_RATE_HZ):
        """The :class:`nniquad.sim.SimOptions` of this scenario for one candidate's inner loops.

        What flies: the position (with this scenario's noise) sampled at ``rate_hz`` and the
        law in discrete time at that rate (``controller_sampling="discrete"``).
        """

        return SimOptions(model="full", horizon_s=horizon_s, output_dt_s=output_dt_s, tilt_limit_deg=tilt_limit_deg,
                          xi0=self.xi0_m, noise_sigma_m=self.noise_sigma_m, noise_rate_hz=float(rate_hz),
                          controller_sampling="discrete", seed=self.noise_seed,
                          wind_N=self.wind_N, motor_lag=motor_lag, tau_motor_s=self.tau_motor_s, inner=inner)

    def params(self, vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, horizon_s: float,
               tilt_limit_deg: float, *, motor_lag: bool = True, rate_hz: float = CONTROL_RATE_HZ):
        """``(SimOptions, SimParams)`` of a candidate: its gains and inner loops on this perturbed plant.

        The gains and inner-loop fields are the candidate's; the plant (mass,
        inertias, motor) and the attitude-gain factor (applied to the candidate's
        ``attitude_gain_scale``) are the scenario's, as in
        :func:`nniquad.scenarios.draws.draw_scenario`.
        """

        opts = self.options(horizon_s, tilt_limit_deg, inner, motor_lag=motor_lag, rate_hz=rate_hz)
        base = SimParams.from_options(vehicle, gains, opts)
        if self.nominal:
            return opts, base
        plant = base.plant
        Jx, Jy = plant.Jx * self.inertia_factors[0], plant.Jy * self.inertia_factors[1]
        Jz = min(plant.Jz * self.inertia_factors[2], Jx + Jy)
        p = base.with_(plant={"m": plant.m * self.mass_factor, "Jx": Jx, "Jy": Jy, "Jz": Jz},
                       inner={"attitude_gain_scale": base.inner.attitude_gain_scale * self.attitude_gain_factor})
        return opts, p

    def equilibrium_m(self, vehicle: Vehicle, gains: GainBlock) -> tuple[float, float]:
        """Static equilibrium under the wind, as in the Monte Carlo study
        (:func:`nniquad.laws.base.wind_equilibrium_m`)."""
        return wind_equilibrium_m(gains, vehicle.m, self.wind_N)

    def to_json(self) -> dict[str, Any]:
        return {"label": self.label, "mass_factor": self.mass_factor, "inertia_factors": list(self.inertia_factors),
                "attitude_gain_factor": self.attitude_gain_factor, "tau_motor_s": self.tau_motor_s,
                "noise_sigma_m": self.noise_sigma_m, "wind_N": list(self.wind_N), "xi0_m": list(self.xi0_m)}


def displacement_radius_m(roa_radius_m: float, max_displacement_m: float) -> float:
    """Radius of the start points: the certified reach the tuner demands (at least ‖ξ_h(0)‖), capped.

    The Monte Carlo study draws its starts from the certificate's certified
    region; the tuner does not know the final certified reach, but every
    admissible candidate certifies ``roa_radius_m``.
    """
    return min(max(float(roa_radius_m), math.hypot(*XI0_M)), float(max_displacement_m))


def tuning_scenarios(vehicle: Vehicle, *, seed: int, roa_radius_m: float, ranges: Any = None,
                     noise_sigma_m: float = 0.0, n_random: int = N_RANDOM) -> list[TuningScenario]:
    """The fixed tuning set (module docstring): nominal first, then the 8 corners, then the random draws.

    Parameters
    ----------
    vehicle
        The nominal vehicle.
    seed
        Seed of the set (noise sequences and random draws); the same seed gives the same set.
    roa_radius_m
        Certified reach the tuner demands (sets the start radius, :func:`displacement_radius_m`).
    ranges
        :class:`nniquad.scenarios.draws.ScenarioRanges` (default the Monte Carlo defaults).
    noise_sigma_m
        Noise σ of the nominal run (the tuner's ``noise_sigma_m``).
    n_random
        Number of random interior draws.

    Returns
    -------
    list of TuningScenario
    """

    r = DEFAULT_RANGES if ranges is None else ranges
    radius = displacement_radius_m(roa_radius_m, r.max_displacement_m)
    tau_range = (r.tau_motor_s if r.tau_motor_s is not None
                 else tuple(vehicle.tau_motor * f for f in r.tau_motor_factor))
    weight = vehicle.m * vehicle.g
    wind_range = r.wind_N if r.wind_N is not None else tuple(weight * f for f in r.wind_weight_fraction)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(2**31,)))  # apart from the MC streams
    out = [TuningScenario("nominal", 1.0, (1.0, 1.0, 1.0), 1.0, vehicle.tau_motor, float(noise_sigma_m),
                          int(rng.integers(0, 2**63 - 1)), (0.0, 0.0), tuple(float(v) for v in XI0_M), nominal=True)]
    ux, uy = (v / math.hypot(*XI0_M) for v in XI0_M)
    start = (radius * ux, radius * uy)
    wind = (wind_range[1] * ux, wind_range[1] * uy)  # pushes along the start displacement: against the return
    for fm, sm in ((r.mass_factor[0], "-"), (r.mass_factor[1], "+")):
        for tau, st in ((tau_range[0], "-"), (tau_range[1], "+")):
            for fa, sa in ((r.attitude_gain_factor[0], "-"), (r.attitude_gain_factor[1], "+")):
                out.append(TuningScenario(f"corner m{sm} tau{st} att{sa}", float(fm), (1.0, 1.0, 1.0), float(fa),
                                          float(tau), float(r.noise_sigma_m[1]), int(rng.integers(0, 2**63 - 1)),
                                          wind, start))
    # random interior draws: the Monte Carlo generator itself, on a setup with the nominal gains

    setup = study_setup_from(vehicle, PAPER_GAINS, region_m=radius, ranges=r)
    for i in range(int(n_random)):
        s = draw_scenario(i, seed, r, setup)
        d = dict(s.factors)
        sp = s.sim_params
        out.append(TuningScenario(f"random {i}", d["mass"], (d["Jx"], d["Jy"], d["Jz"]), d["attitude_gain"],
                                  sp.plant.tau_motor, s.noise_sigma_m, s.noise_seed,
                                  (sp.run.wind_x, sp.run.wind_y), s.xi0_m))
    return out
