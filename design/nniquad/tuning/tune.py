"""Gain tuning under the sector bound: the fastest certified (kp, Γ, δ).

Problem
-------
Minimise the settling time (2 % band, last exit; :mod:`nniquad.sim.metrics`) of the
``reduced`` or ``full`` model from the paper's initial state over the gains,
subject to

* the sector bound ``δ >= 1/(γ_max m kp)`` (the paper's condition, γ_max = 0.8
  by default); because ``γ_max < 1`` it implies the exact stability condition
  ``m kp δ > 1`` of the reduced loop (:mod:`nniquad.analysis.reduced_loop`);
* the tilt limit (built into both models as a limit on the commanded tilt; for
  ``full`` the **actual** tilt must also stay within the limit plus 1°) and the
  rotor-speed limits (modelled as saturation in ``full``);
* optionally a certified reach: the region-of-attraction LMI under tilt
  saturation (:func:`nniquad.analysis.lmi.certified_reach`) must certify every
  displacement from rest up to ``roa_radius_m``;
* optionally robustness: the worst settling time over the true masses
  ``mass_range`` (controller at the nominal mass) and/or under position noise.
* by default on ``full`` (``objective="robust"``): the cost is the p95
  (:data:`ROBUST_QUANTILE`) of the honest settling times over a fixed scenario set
  with common random numbers (:mod:`nniquad.tuning.robust_scenarios`: nominal, the 8
  corners mass × motor lag × attitude gain, 11 Monte Carlo draws), every scenario
  required to settle without altitude loss, divergence or tilt above limit + 1°
  (:func:`nniquad.tuning.objective.robust_cost`); ``"nominal"`` restores the single run;
* by default on ``full`` (``require_margins``): GM >= 6 dB both ways at both break
  points of the linearised cascade (:func:`nniquad.tuning.objective.margin_penalty`,
  lazily for otherwise admissible candidates), and the phase margins reported
  against 45° (``require_pm`` ranks them too: the horizontal PM of this law is at
  most 41.8° at γ_max = 0.8, so no candidate meets it and the search would keep
  the one with the smallest shortfall); ``TuneResult.margins_met`` says whether
  both break points meet GM 6 dB and PM 45°.

Coordinates
-----------
The search runs in well-scaled coordinates in which the sector bound is a
simple bound::

    q0 = ln kp,   q1 = u = ln(γ_max m kp δ) >= 0,   q2 = ln(Γ δ),
    [q3 = ln ω_a,   q4 = ζ_a,   q5 = α / α_avail]

``Γδ`` is the controller pole (1/s), at most min(π f_s, 2.5/dt): below the
Nyquist frequency of the 100 Hz position samples and inside the RK4 step's
stability region; kp is bounded by what the vehicle's attitude loop and tilt
limit realise (:func:`nniquad.tuning.vehicle_limits.gain_limits`).  The PD laws
(``TuneOptions.controller``) search ``ln kp``, the damping ratio
``k_d/(2√k_p)`` and, filtered, ``ln τ_f`` instead.  For ``full`` the attitude loop is
tuned as well (q3..q5: natural frequency, damping, and the deceleration of the
square-root error shaping of :mod:`nniquad.control.inner_loops` as a fraction of
:func:`attitude_accel_headroom`), because the NNI loop's speed is limited by
how fast the vehicle can reverse its tilt with the rotor torque it has left
at the tilt limit.

Method and why
--------------
Settling time is piecewise smooth with jumps (an oscillation peak leaving or
entering the band moves the last exit by half a period), so gradients are
useless and a single local search stalls in a false minimum.  Two stages:

1. **Global sweep**: a scrambled Sobol sequence in the box (seeded), half of
   it on the sector-bound face u = 0 where the fastest designs lie
   (:func:`initial_design`), every point simulated in one CasADi ``map`` batch.
   The best distinct admissible points (10 % of the box apart) are the starts.
2. **Derivative-free optimiser** from those starts, fed with batches of
   candidates (one batched simulation each), in the box normalised to
   [0, 1]^d, for a fixed number of evaluations (:data:`BUDGETS`);
   :mod:`nniquad.tuning.optimizers`, chosen with ``TuneOptions.optimizer``:

   * ``"cma"`` (default): CMA-ES (Hansen & Ostermeier, Evol. Comput. 9(2),
     2001) with BIPOP restarts (Hansen, GECCO 2009): IPOP runs with doubling
     populations (Auger & Hansen, CEC 2005) from the other starts,
     interleaved with small-population local runs from the incumbent; one
     generation per batch.
   * ``"nomad"``: NOMAD 4 (Le Digabel, ACM Trans. Math. Softw. 37(4), 2011),
     the Mesh Adaptive Direct Search of Audet & Dennis (SIAM J. Optim. 17(1),
     2006) with orthogonal 2n poll directions, whose dense poll directions
     give convergence to Clarke-stationary points of non-smooth functions;
     search and poll points of an iteration form one block, and a converged
     run restarts from the next start.

   The certified-reach LMI is solved only for a candidate that would become
   the incumbent; an inadmissible one is told to the optimiser at cost +
   horizon.  With the *nominal* objective on the paper's vehicle (``full``,
   reach off, 256 sweep points and 400 optimiser evaluations per seed) five
   seeds of CMA-ES landed within 0.64 % of the best of them (best 2.447 s)
   and five of NOMAD within 1.06 % (best 2.446 s), NOMAD taking 40 % more
   wall time for the same simulations (its quadratic-model search); the two
   are equal in quality within the scatter of five seeds, and CMA-ES is the
   default for its speed.  The robust objective (the default on ``full``) is
   much rougher: the p95 of 20 scenarios jumps when one scenario's last exit
   from the band moves.  At the robust default (``normal``, paper class) five
   seeds ended 11.2 % apart while the first CMA run spent the whole budget,
   3.7 % apart once it could spend only half of it
   (:data:`nniquad.tuning.optimizers.CMA_FIRST_RUN_SHARE`; docs/notes/tuning.md), and
   0.62 % apart since BIPOP's small runs search in the frame the large run
   learned (:data:`nniquad.tuning.optimizers.SMALL_RUNS_IN_LEARNED_FRAME`;
   docs/notes/tuning.md); ``benchmarks/bench_optimizers.py`` measures it.

:func:`tune` reruns everything from other seeds (``TuneOptions.reruns``),
keeps the best, and reports the per-seed optima and their spread, so an
optimum that is an artefact of one seed shows up.  The same seed gives the
same result: the Sobol scrambling and every random choice of both optimisers
derive from it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from nniquad import config
from nniquad.analysis.bound import BoundResult, time_optimal_bound
from nniquad.analysis.lmi.reduced_region import certified_reach
from nniquad.analysis.reduced_loop import ReducedLoop, reduced_loop
from nniquad.config import BAND_FRACTION, REQUIRED_GM_DB, REQUIRED_PM_DEG, XI0_NORM_M
from nniquad.format import margin_text, margin_verdict
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import NniquadError
from nniquad.laws.base import GainBlock
from nniquad.laws.classes import LAW_CLASSES
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle
from nniquad.scenarios.draws import DEFAULT_RANGES
from nniquad.sim.options import check_rate_hz
from nniquad.sim.verdicts import Metrics
from nniquad.tuning.coordinates import decode, encode, search_box, tunable_law, warm_start_coordinates
from nniquad.tuning.objective import (
    MARGIN_PENALTY_WIDTH_S,
    evaluate,
    evaluate_details,
    honest_horizon_s,
    required_hold_s,
    robust_scenarios,
    settling_shown,
    simulation_options,
    simulations_run,
    tau_cap,
    tracking_rms_of_cost,
)
from nniquad.tuning.optimizers import minimise
from nniquad.tuning.robust_scenarios import displacement_radius_m
from nniquad.tuning.search import Candidate, SearchState, global_sweep, initial_design, optimiser_starts
from nniquad.tuning.tune_options import (
    ALTITUDE_CAP_M,
    BUDGETS,
    DEFAULT_OPTIMIZER,
    DEFAULT_ROA_RADIUS_M,
    LONGEST_SETTLING_BANDS,
    OPTIMIZERS,
    ROBUST_QUANTILE,
    ROBUST_RETRY_BANDS,
    SCREEN_KEEP_PER_START,
    SECTOR_FACE_SHARE,
    TILT_SLACK_DEG,
    TuneOptions,
    budget_of,
)
from nniquad.tuning.vehicle_limits import attitude_accel_headroom, attitude_wn_cap, gain_limits

__all__ = [
    "TuneOptions",
    "Candidate",
    "TuneResult",
    "decode",
    "encode",
    "search_box",
    "tune",
    "simulation_options",
    "evaluate",
    "attitude_accel_headroom",
    "attitude_wn_cap",
    "required_hold_s",
    "settling_shown",
    "honest_horizon_s",
    "initial_design",
    "SECTOR_FACE_SHARE",
    "DEFAULT_ROA_RADIUS_M",
    "BUDGETS",
    "OPTIMIZERS",
    "DEFAULT_OPTIMIZER",
    "minimise",
    "TILT_SLACK_DEG",
    "ALTITUDE_CAP_M",
    "ROBUST_QUANTILE",
    "default_horizon_s",
    "warm_start_coordinates",
]


# ----------------------------------------------------------------------------- result


@dataclass
class TuneResult:
    """The tuned gain set and how it was found.

    Attributes
    ----------
    vehicle, options
        What was tuned.
    gains, inner
        The best gain set and the inner-loop gains it goes with.
    settling_s
        Its worst-case settling time over the tuning scenarios [s].
    metrics
        Nominal-scenario metrics.
    certified_reach_m
        Largest displacement from rest its region-of-attraction LMI certifies [m].
    bound
        The time-optimal bound; ``ratio_to_bound`` = settling / ``enter_band_s``.
    horizon_s
        Simulated time of every candidate [s].
    reruns
        ``[{seed, settling_s, gains}]`` of the artefact check (seed of the main run first).
    n_simulations, n_lmi
        Simulations run and region-of-attraction LMIs solved.
    elapsed_s
        Wall time of the tuning [s].
    tradeoffs
        Labelled key numbers for the report.
    objective
        ``"robust"`` or ``"nominal"`` (:attr:`TuneOptions.objective`); with ``"robust"``,
        :attr:`settling_s` is the p95 (``options.ROBUST_QUANTILE``) over the tuning scenarios.
    nominal_settling_s
        Honest settling time of the nominal scenario [s] (``None`` if it is not shown).
    scenario_count
        Number of tuning scenarios (1 + the mass / margin ones for ``"nominal"``).
    worst_scenario
        ``{label, cost_s, ...}`` of the scenario with the largest cost (robust), else ``None``.
    scenario_costs
        ``[{label, cost_s}]`` of every robust scenario (cost = honest settling time when admissible).
    margins
        Fast classical margins at both break points (:mod:`nniquad.analysis.fast_margins`), JSON form;
        ``None`` for the reduced model.
    margins_met
        Whether every margin requirement is met (``None`` if not required).  ``False`` means the
        tuner fell back to the design with the smallest shortfall (no design met it).
    tracking_rms_m, tracking_max_m
        With a reference (the tracking objective, :attr:`TuneOptions.reference`): RMS and maximum tracking error
        [m] of the tuned design over the window of its tracking run; ``None`` without one.
    """

    vehicle: Vehicle
    options: TuneOptions
    gains: GainBlock
    inner: InnerLoopGains
    settling_s: float
    metrics: Metrics
    certified_reach_m: float
    bound: BoundResult
    horizon_s: float
    reruns: list[dict[str, Any]] = field(default_factory=list)
    n_simulations: int = 0
    n_lmi: int = 0
    elapsed_s: float = 0.0
    tradeoffs: list[dict[str, Any]] = field(default_factory=list)
    objective: str = "nominal"
    nominal_settling_s: float | None = None
    scenario_count: int = 1
    worst_scenario: dict[str, Any] | None = None
    scenario_costs: list[dict[str, Any]] = field(default_factory=list)
    margins: dict[str, Any] | None = None
    margins_met: bool | None = None
    tracking_rms_m: float | None = None
    tracking_max_m: float | None = None

    def objective_statement(self) -> str:
        """What was optimised and subject to what, in words (printed by ``nniquad tune``, in its JSON)."""
        o = self.options
        if o.objective == "robust":
            settling = (f"p{ROBUST_QUANTILE * 100:g} settling time over the {self.scenario_count} robust scenarios "
                        f"(each settles, no altitude loss)")
        else:
            settling = "settling time of the nominal run" + (" and the mass-range / margin runs" if
                                                            (o.mass_range or o.margin) else "")
        cons = [f"{settling} shown within the {self.horizon_s:.3g} s horizon"]
        if o.law.ni_structure and o.law_class == "paper":
            cons.append(f"sector bound gamma <= {o.gamma_max:g}")
        if o.roa_radius_m > 0:
            cons.append(f"certified reach >= {o.roa_radius_m:g} m")
        if o.require_margins:
            cons.append(f"GM >= {REQUIRED_GM_DB:g} dB both ways at both break points")
        if not o.tracking:
            return f"objective: minimise the {settling}; subject to: {'; '.join(cons[1:]) or 'nothing else'}"
        t0, t1 = o.tracking_window
        ff = (("with feedforward" + (f" read {o.feedforward_lead_s:g} s ahead" if o.feedforward_lead_s else ""))
              if o.feedforward else "without feedforward")
        return (f"objective: RMS tracking error on {o.reference.describe()} {ff} over [{t0:g}, {t1:g}] s "
                f"(nominal run started on the reference with its velocity); subject to: settles from the start "
                f"({'; '.join(cons)}); the tracking run not lost")

    def __repr__(self) -> str:
        gains = ", ".join(f"{k}={v:.5g}" for k, v in self.gains.as_dict().items() if v is not None)
        reach = (f", certified reach {self.certified_reach_m:.3g} m" if math.isfinite(self.certified_reach_m)
                 else f", {self.options.controller}: no certified region")
        return (f"TuneResult(model={self.options.model!r}, {gains}, "
                f"settling {self.settling_s:.4g} s = {self.ratio_to_bound:.3g} x bound{reach})")

    @property
    def roa_radius_m(self) -> float:
        return self.options.roa_radius_m

    @property
    def ratio_to_bound(self) -> float:
        return self.settling_s / self.bound.enter_band_s

    @property
    def gamma(self) -> float:
        """Smallest γ the gains satisfy the sector bound with: the DC loop gain (``nan`` for a law outside the NI
        structure: no sector bound)."""
        if not self.gains.law.ni_structure:
            return math.nan
        return ReducedLoop.from_vehicle(self.vehicle, self.gains).smallest_gamma

    def nni_image(self) -> dict[str, Any] | None:
        """The NNI image of a design outside the NI structure that has one (a filtered PD's,
        :meth:`nniquad.laws.base.ControlLaw.ni_image`), its sector constant and the classes it lies in
        (:meth:`nniquad.tuning.coordinates.TunableLaw.image_violation`); ``None`` for every other design."""
        law, m = self.gains.law, self.vehicle.m
        image = None if law.ni_structure else law.ni_image(self.gains, m)
        if image is None:
            return None
        lim = gain_limits(self.vehicle, self.options.tilt_limit_deg)
        inside = {c: tunable_law(law.name, c).image_violation(self.gains, m, self.options.gamma_max, lim["kp_max"],
                                                              lim["gamma_delta_max"]) == 0
                  for c in LAW_CLASSES if c in law.law_classes}
        return {**image.law.gains_json(image), "gamma": image.law.sector_constant(image, m), "in_class": inside}

    def rerun_spread_s(self) -> float:
        """Largest minus smallest best settling time over the seeds [s]."""
        s = [r.get("settling_s") for r in self.reruns]
        s = [v for v in s if v is not None]
        return float(max(s) - min(s)) if s else 0.0

    def rerun_tracking_spread_m(self) -> float | None:
        """Largest minus smallest best RMS tracking error over the seeds [m] (tracking objective), else ``None``."""
        s = [r["tracking_rms_m"] for r in self.reruns if r.get("tracking_rms_m") is not None]
        return float(max(s) - min(s)) if s else None

    def to_json(self) -> dict[str, Any]:
        return {
            "model": self.options.model,
            "options": self.options.to_json(),
            "vehicle": self.vehicle.name,
            "gains": self.gains.as_dict(),
            "inner_loop": self.inner.as_dict(),
            "settling_s": self.settling_s,
            "metrics": self.metrics.to_json(),
            "controller": self.options.controller,
            "law_class": self.options.law_class,
            "nni_image": self.nni_image(),
            "sector": ({"gamma": self.gamma, "gamma_max": self.options.gamma_max}
                       if math.isfinite(self.gamma) else None),
            "roa_radius_m": self.roa_radius_m,
            "certified_reach_m": self.certified_reach_m if math.isfinite(self.certified_reach_m) else None,
            "start_certified": bool(self.certified_reach_m >= DEFAULT_ROA_RADIUS_M),
            "enter_band_s": self.bound.enter_band_s,
            "ratio_to_bound": self.ratio_to_bound,
            "horizon_s": self.horizon_s,
            "reruns": self.reruns,
            "rerun_spread_s": self.rerun_spread_s(),
            "n_simulations": self.n_simulations,
            "n_lmi": self.n_lmi,
            "elapsed_s": self.elapsed_s,
            "tradeoffs": self.tradeoffs,
            "objective": self.objective,
            "robust_quantile": ROBUST_QUANTILE if self.objective == "robust" else None,
            "nominal_settling_s": self.nominal_settling_s,
            "scenario_count": self.scenario_count,
            "scenario_seed": self.options.scenario_seed if self.objective == "robust" else None,
            "scenario_noise_range_m": list(self.options.robust_noise_range_m) if self.objective == "robust" else None,
            "scenario_wind_fraction_range": (list(self.options.robust_wind_fraction_range)
                                             if self.objective == "robust" else None),
            "scenario_delay_samples": self.options.delay_samples if self.objective == "robust" else None,
            "worst_scenario": self.worst_scenario,
            "scenario_costs": self.scenario_costs,
            "margins": self.margins,
            "margins_met": self.margins_met,
            "objective_statement": self.objective_statement(),
            **({} if not self.options.tracking else {"tracking": {
                "reference": self.options.reference.describe(), "feedforward": self.options.feedforward,
                "feedforward_lead_s": self.options.feedforward_lead_s,
                "tracking_window_s": list(self.options.tracking_window),
                "tracking_rms_m": self.tracking_rms_m, "tracking_max_m": self.tracking_max_m}}),
        }


def _one_seed(search: SearchState, seed: int, extra: list[Candidate]) -> tuple[Candidate, list[Candidate]]:
    """Sweep and optimise with one seed: its optimum, and the optimiser's incumbents (best first).

    ``extra`` (evaluated warm starts) compete with the sweep's points for the starts.
    """
    options = search.options
    n_global, k, n_evals, _ = budget_of(options)
    # the attitude coordinates double the dimension: sample twice as densely, search twice as long
    scale = 2 if len(search.lo) > 3 else 1
    ranked = sorted(global_sweep(search, n_global * scale, seed), key=lambda c: c.cost)
    if options.robust or options.require_margins:  # the sweep screened on the nominal run: rank again in full
        ranked = search.evaluate(np.array([c.q for c in ranked[:SCREEN_KEEP_PER_START * k]]))
    ranked = sorted(ranked + extra, key=lambda c: c.cost)
    starts = optimiser_starts(search, ranked, k)
    if not starts:
        raise NniquadError(
            f"no gain set among the best of the sweep certifies a reach of "
            f"{search.options.roa_radius_m:g} m (use a larger --budget, a smaller --roa-radius, or 0 to switch "
            "the check off)"
        )
    max_evals = n_evals if options.robust else n_evals * scale  # ROBUST_BUDGETS are final numbers
    found = minimise(search, starts, method=options.optimizer, max_evals=max_evals, seed=seed)
    return found[0], found


def tune(vehicle: Vehicle = PAPER_VEHICLE, options: TuneOptions | None = None,
         progress: Callable[[str], None] | None = None,
         warm_starts: Sequence[tuple[GainBlock, InnerLoopGains]] = ()) -> TuneResult:
    """Fastest admissible gain set (module docstring).

    Parameters
    ----------
    vehicle
        The vehicle (nominal controller model and plant).
    options
        :class:`TuneOptions`; default: reduced model, γ_max 0.8, reach ‖ξ_h(0)‖.
    progress
        Called with a one-line status message now and then.
    warm_starts
        Gain sets (with their inner loops) to refine from as well, e.g. the
        optimum of a less constrained run or a filtered PD (mapped into the NNI
        law, :func:`warm_start_coordinates`); used only inside the search box
        and where admissible.  Each is evaluated on the full objective and
        competes with the sweep's best points for the optimiser's starts, so a
        result is never worse than the best admissible warm start.

    Returns
    -------
    TuneResult

    Raises
    ------
    NniquadError
        Bad options, or no admissible gain set found.
    """
    options = TuneOptions() if options is None else options

    check_rate_hz(options.rate_hz, option="rate", error=NniquadError)  # a period of whole RK4 steps
    t0 = time.perf_counter()
    say = progress or (lambda msg: None)
    bound = time_optimal_bound(vehicle, tilt_limit_deg=options.tilt_limit_deg)
    horizon = options.horizon_s if options.horizon_s is not None else default_horizon_s(vehicle, options, bound)
    runs0 = simulations_run()
    n_reruns = budget_of(options)[3] if options.reruns is None else options.reruns
    alpha = attitude_accel_headroom(vehicle, options.tilt_limit_deg)
    horizons = [horizon]
    if options.horizon_s is None and options.robust:
        # a smaller or weaker vehicle's robust corners may settle later than the default horizon can show:
        # search again, once, on a horizon that shows ROBUST_RETRY_BANDS x enter_band_s
        horizons.append(max(horizon, honest_horizon_s(ROBUST_RETRY_BANDS * bound.enter_band_s)))
    for attempt, horizon in enumerate(horizons):
        search = SearchState(vehicle, options, horizon, lambda msg: say(f"seed {seed}: {msg}"))
        extra: list[Candidate] = []
        if warm_starts:
            qs = warm_start_coordinates(vehicle, options, warm_starts, alpha)
            inside = [q for q in qs if q is not None and np.all(q >= search.lo - 1e-12) and np.all(q <= search.hi + 1e-12)]
            if attempt == 0:
                say(f"{len(inside)} of {len(qs)} warm starts lie in the {options.controller} search box"
                    + (f" of the {options.law_class} class" if options.law_class else ""))
            if inside:
                extra = search.evaluate(np.array(inside))
        results: list[tuple[int, Candidate]] = []
        for seed in [options.seed + i for i in range(n_reruns + 1)]:
            best_seed, _ = _one_seed(search, seed, extra)
            results.append((seed, best_seed))
        _, best = min(results, key=lambda sc: sc[1].cost)
        if best.cost < horizon + MARGIN_PENALTY_WIDTH_S or attempt == len(horizons) - 1:
            break
        say(f"no gain set passed every robust scenario within the {horizon:g} s horizon; searching again "
            f"on {horizons[attempt + 1]:g} s")
    gains, inner = decode(best.q, vehicle.m, options.gamma_max, alpha_avail=alpha,
                          tau_motor_s=tau_cap(vehicle, options), controller=options.controller,
                          law_class=options.law_class)
    details = evaluate_details(vehicle, best.q[None], options, horizon, full_report=True)[0]
    margins_met: bool | None = None
    if options.require_margins:
        margins_met = details["margins"] is not None and all(m.meets_requirement for m in details["margins"].values())
    if options.tracking and details["cost_without_margins"] < horizon and details["tracking_rms_m"] is None:
        raise NniquadError(f"no admissible gain set followed {options.reference.describe()} on the {options.model} "
                           "model without losing the vehicle (use a larger --budget or a slower reference)")
    if best.cost >= horizon and not (options.require_margins and details["cost_without_margins"] < horizon):
        if options.robust and details["nominal_cost"] < horizon and details["scenario_costs"] is not None:
            scen = robust_scenarios(vehicle, options)
            failed = [s.label for s, c in zip(scen, details["scenario_costs"]) if c is not None and c >= horizon]
            raise NniquadError(
                f"no gain set met every robust scenario on the {options.model} model within the {horizon:g} s "
                f"horizon (settled, no altitude loss, actual tilt <= limit + {TILT_SLACK_DEG:g} deg); the best "
                f"fails {len(failed)} of {len(scen)}: {', '.join(failed[:3])} (use a larger --budget, or --nominal)"
            )
        longest = horizon - required_hold_s(horizon / (1.0 + config.SETTLING_HOLD_FACTOR))
        raise NniquadError(
            f"no gain set settled within the {horizon:g} s horizon on the {options.model} model "
            f"(best candidate did not settle{', objective ' + options.objective if options.model == 'full' else ''}; "
            f"a settling time counts only if the run then stays in the band for max(5 s, 2 x settling), so at most "
            f"about {longest:.3g} s here): use a larger --budget" + (" or --nominal" if options.robust else "")
        )
    if margins_met is False:
        # the horizontal PM of this law is at most asin(γ/(2-γ)), 41.8° at γ = 0.8, on the ideal double
        # integrator: stated, not hidden
        what = "; ".join(f"{k} {margin_text(m.gm_db, m.gm_lower_db, m.pm_deg)}: "
                         f"{margin_verdict(m.to_json(), REQUIRED_GM_DB, REQUIRED_PM_DEG)}"
                         for k, m in (details["margins"] or {}).items())
        say(f"the design misses its margin requirement ({what}; "
            + ("smallest shortfall kept)" if options.require_pm else "gain margins enforced, PM reported)"))
    robust_info = _robust_summary(vehicle, options, details)
    if not options.law.ni_structure:
        reach = math.nan  # not a design of the NI structure: no certified region
    elif best.reach_m is not None:
        reach = best.reach_m
    else:
        reach = certified_reach(reduced_loop(vehicle, gains), options.tilt_limit_deg)
    reruns = []
    for seed, cand in results:
        g, inn = decode(cand.q, vehicle.m, options.gamma_max, alpha_avail=alpha, tau_motor_s=tau_cap(vehicle, options),
                        controller=options.controller, law_class=options.law_class)
        # with the tracking objective the cost is the mapped RMS, and the settling time is a constraint
        rerun = ({"settling_s": cand.cost} if not options.tracking
                 else {"tracking_rms_m": tracking_rms_of_cost(cand.cost, horizon)})
        reruns.append({"seed": seed, **rerun, "gains": g.as_dict(), "inner_loop": inn.as_dict()})
    settling = details["cost_without_margins"]
    return TuneResult(vehicle=vehicle, options=options, gains=gains, inner=inner, settling_s=settling,
                      metrics=best.metrics, certified_reach_m=reach, bound=bound, horizon_s=horizon,
                      reruns=reruns, n_simulations=max(search.n_sim, simulations_run() - runs0), n_lmi=search.n_lmi,
                      elapsed_s=time.perf_counter() - t0, objective=options.objective,
                      nominal_settling_s=details["nominal_cost"] if details["nominal_cost"] < horizon else None,
                      margins=(None if details["margins"] is None
                               else {k: m.to_json() for k, m in details["margins"].items()}),
                      margins_met=margins_met, tracking_rms_m=details.get("tracking_rms_m"),
                      tracking_max_m=details.get("tracking_max_m"), **robust_info)


def default_horizon_s(vehicle: Vehicle, options: TuneOptions, bound: BoundResult | None = None) -> float:
    """The tuner's horizon: :func:`honest_horizon_s` of ``LONGEST_SETTLING_BANDS × enter_band_s``.

    With the robust objective the scenarios start up to the displacement radius
    (:func:`nniquad.tuning.robust_scenarios.displacement_radius_m`), farther than the
    nominal start when a larger reach is demanded; the time-optimal bound of the
    farthest start then sets the horizon, so that the longest settling time that
    can count is as long for every scenario.
    """

    bound = time_optimal_bound(vehicle, tilt_limit_deg=options.tilt_limit_deg) if bound is None else bound
    enter = bound.enter_band_s
    if options.robust:
        r = displacement_radius_m(options.roa_radius_m, DEFAULT_RANGES.max_displacement_m)
        far = time_optimal_bound(vehicle, xi0=(r, 0.0), tilt_limit_deg=options.tilt_limit_deg,
                                 band_fraction=BAND_FRACTION * XI0_NORM_M / r)
        enter = max(enter, far.enter_band_s)
    return honest_horizon_s(LONGEST_SETTLING_BANDS * enter)


def _robust_summary(vehicle: Vehicle, options: TuneOptions, details: dict[str, Any]) -> dict[str, Any]:
    """``scenario_count``, ``worst_scenario`` and ``scenario_costs`` of the winner (robust objective)."""
    if not options.robust or details["scenario_costs"] is None:
        return {"scenario_count": 1, "worst_scenario": None, "scenario_costs": []}
    scen = robust_scenarios(vehicle, options)
    costs = [{"label": s.label, "cost_s": c, **s.to_json()} for s, c in zip(scen, details["scenario_costs"])]
    worst = max(costs, key=lambda d: -1.0 if d["cost_s"] is None else d["cost_s"])
    return {"scenario_count": len(scen), "worst_scenario": worst,
            "scenario_costs": [{"label": d["label"], "cost_s": d["cost_s"]} for d in costs]}
