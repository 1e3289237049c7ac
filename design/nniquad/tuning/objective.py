"""What a candidate costs: its simulation settings, scenarios, the honest-settling rule and the cost."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from nniquad import config
from nniquad.analysis.fast_margins import design_margins, margin_shortfall
from nniquad.config import BAND_FRACTION, XI0_NORM_M
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.errors import CascadeError
from nniquad.model.vehicle import Vehicle
from nniquad.scenarios.ranges import DEFAULT_RANGES
from nniquad.sim import SimOptions, simulate
from nniquad.sim.metrics import settling_time_batch
from nniquad.sim.verdicts import Metrics, compute_metrics
from nniquad.tuning.coordinates import decode, tunable_law
from nniquad.tuning.robust_scenarios import tuning_scenarios
from nniquad.tuning.tune_options import (
    ALTITUDE_CAP_M,
    MARGIN_NOISE_M,
    MARGIN_TAU_FACTOR,
    ROBUST_QUANTILE,
    ROBUST_TILT_SLACK_DEG,
    TILT_SLACK_DEG,
    TRACKING_COST_SCALE_M,
    TuneOptions,
)
from nniquad.tuning.vehicle_limits import attitude_accel_headroom, gain_limits

# ----------------------------------------------------------------------------- evaluation


def simulation_options(options: TuneOptions, horizon_s: float, inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS):
    """The :class:`nniquad.sim.SimOptions` every candidate is simulated with (nominal mass).

    ``full``: what flies, the position sampled at ``options.rate_hz`` and the law in
    discrete time (the certificate's ``full`` reference run and ``nniquad export``);
    ``reduced``: the paper's continuous loop.
    """

    opts = SimOptions(model=options.model, horizon_s=horizon_s, output_dt_s=0.005,
                      tilt_limit_deg=options.tilt_limit_deg, noise_sigma_m=options.noise_sigma_m,
                      seed=options.seed, motor_lag=options.motor_lag and options.model == "full", inner=inner)
    if options.model == "full":
        opts = opts.with_(controller_sampling="discrete", noise_rate_hz=options.rate_hz)
    return opts


def scenario_options(options: TuneOptions, base, vehicle: Vehicle) -> list:
    """Nominal, the mass-range ends when asked for, and the ``full`` margin scenario (cost: the worst)."""
    out = [base]
    if options.mass_range is not None:
        out += [base.with_(true_mass_kg=mm) for mm in options.mass_range]
    if options.model == "full" and options.margin:
        # a design tuned to the edge of the nominal motor lag loses altitude a few ms later
        # (Monte Carlo finding): demand the same performance with slower motors and a noisy sensor
        out.append(base.with_(motor_lag=True, tau_motor_s=MARGIN_TAU_FACTOR * vehicle.tau_motor,
                              noise_sigma_m=max(base.noise_sigma_m, MARGIN_NOISE_M), noise_rate_hz=options.rate_hz))
    return out


def required_hold_s(settling_s: float) -> float:
    """How long a run must be seen inside the band after its settling time: ``max(5 s, 2 × settling)``.

    A last exit at ``s`` on a horizon ``T`` proves nothing about ``t > T``; a slowly
    growing or slowly decaying oscillation can leave the band again after the
    horizon (a tuner horizon of 6.9 s accepted 6.81 s whose 20 s certificate runs
    did not settle).  Requiring the run to stay in for twice its settling time
    (and at least 5 s) rules out a return of any mode slower than the settling itself.

    Parameters
    ----------
    settling_s
        Settling time [s] (last exit from the band).

    Returns
    -------
    float
        The hold time [s] (``config.SETTLING_HOLD_MIN_S``, ``config.SETTLING_HOLD_FACTOR``).
    """
    return max(config.SETTLING_HOLD_MIN_S, config.SETTLING_HOLD_FACTOR * float(settling_s))


def settling_shown(settling_s: float | None, horizon_s: float) -> bool:
    """Whether a settling time counts: the run stays in the band for :func:`required_hold_s` after it.

    Parameters
    ----------
    settling_s
        Settling time [s], or None (never settled).
    horizon_s
        Horizon of the run [s].

    Returns
    -------
    bool
        ``settling_s + required_hold_s(settling_s) <= horizon_s``.
    """
    if settling_s is None or not math.isfinite(settling_s):
        return False
    return settling_s + required_hold_s(settling_s) <= horizon_s + 1e-9


def honest_horizon_s(longest_settling_s: float) -> float:
    """Horizon on which settling times up to ``longest_settling_s`` can be shown (:func:`settling_shown`)."""
    return longest_settling_s + required_hold_s(longest_settling_s)


def _cost(metrics: Metrics, xy_end: np.ndarray, xi0_norm: float, horizon: float, tilt_cap: float | None) -> float:
    """Settling time, or a penalty above every feasible value that still ranks the failures.

    The settling time counts only if :func:`settling_shown` on this horizon; a last
    exit ``s`` that is not shown costs ``horizon + s`` (ranked, but above every shown one).
    Not settled: ``horizon (2 + min(‖ξ(T)‖/‖ξ(0)‖, 10))``, plus ``horizon (1 + excess
    in m)`` for an altitude deviation above :data:`ALTITUDE_CAP_M`; at most
    ``horizon (13 + L - cap)`` with ``L`` = :data:`nniquad.config.ALTITUDE_LIMIT_M`.
    Lost (:attr:`Metrics.diverged`, the project's one verdict: blown up, or the
    altitude lost beyond ``L``): ``horizon (14 + L - cap)``, above every run that
    is not lost, plus ``horizon`` per metre fallen beyond ``L`` (the further it
    fell, the more it costs: failures stay ranked).  On every run, actual tilt
    above ``tilt_cap``: ``horizon (1 + excess in deg)`` added.
    """
    if metrics.diverged or not np.all(np.isfinite(xy_end)):
        cost = horizon * (14.0 + config.ALTITUDE_LIMIT_M - ALTITUDE_CAP_M)
        if metrics.altitude_dev_m is not None and metrics.altitude_dev_m > config.ALTITUDE_LIMIT_M:
            cost += horizon * (metrics.altitude_dev_m - config.ALTITUDE_LIMIT_M)
    else:
        if metrics.settling_s is not None and not settling_shown(metrics.settling_s, horizon):
            # in the band at the end but not shown to stay: ranked by its last exit, above every shown settling
            cost = horizon + float(metrics.settling_s)
        elif metrics.settling_s is None:
            cost = horizon * (2.0 + min(float(np.hypot(*xy_end)) / xi0_norm, 10.0))
        else:
            cost = float(metrics.settling_s)
        if metrics.altitude_dev_m is not None and metrics.altitude_dev_m > ALTITUDE_CAP_M:
            cost += horizon * (1.0 + metrics.altitude_dev_m - ALTITUDE_CAP_M)
    if tilt_cap is not None and metrics.peak_tilt_deg is not None and metrics.peak_tilt_deg > tilt_cap:
        cost += horizon * (1.0 + metrics.peak_tilt_deg - tilt_cap)
    return cost


def tau_cap(vehicle: Vehicle, options: TuneOptions) -> float | None:
    """Nominal motor time constant that caps ω_a (``full`` with motor lag), else ``None``."""
    return vehicle.tau_motor if (options.model == "full" and options.motor_lag) else None


def evaluate(vehicle: Vehicle, points: np.ndarray, options: TuneOptions, horizon_s: float,
             inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS, *,
             prune_above: float | None = None) -> tuple[np.ndarray, list[Metrics]]:
    """Cost and nominal metrics of many points in search coordinates, batched simulations.

    Nominal objective: the worst :func:`_cost` over the nominal scenario and the
    ``mass_range`` / ``margin`` scenarios.  Robust objective
    (``options.objective == "robust"``): additionally the fixed tuning set
    (:func:`robust_costs`), simulated only for the candidates whose nominal cost is
    admissible (a candidate that fails its nominal run pays the penalty anyway);
    the cost is then :func:`robust_cost` of all scenario costs.  With
    ``options.require_margins`` every candidate that is otherwise admissible has
    its classical margins checked (:func:`margin_penalty`, lazily: only those).

    Returns
    -------
    cost : ndarray (B,)
        The cost (admissible values are settling times below the horizon; every
        penalty lies above the horizon).
    metrics : list of Metrics
        Of the nominal scenario.

    ``prune_above`` (robust objective): see :func:`evaluate_details`.
    """
    details = evaluate_details(vehicle, points, options, horizon_s, inner, prune_above=prune_above)
    return np.array([d["cost"] for d in details]), [d["metrics"] for d in details]


def _decode_all(vehicle: Vehicle, pts: np.ndarray, options: TuneOptions, inner: InnerLoopGains) -> list:
    alpha = attitude_accel_headroom(vehicle, options.tilt_limit_deg)
    return [decode(q, vehicle.m, options.gamma_max, inner, alpha, tau_cap(vehicle, options), options.controller,
                   options.law_class) for q in pts]


#: Cost of a filtered PD whose NNI image lies outside its law class, per unit of violation (log units), in
#: horizons on top of the largest simulation penalty (12 horizons): above every simulated candidate, ranked.
CLASS_PENALTY_HORIZONS = 12.0


def class_violations(vehicle: Vehicle, decoded: list, options: TuneOptions) -> np.ndarray:
    """How far each candidate's NNI image lies outside the law class's box (0 inside;
    :meth:`nniquad.tuning.coordinates.TunableLaw.image_violation`).

    Zero for every candidate unless a law is tuned in a class through its image (a filtered PD).

    Parameters
    ----------
    vehicle
        The vehicle.
    decoded
        ``(gains, inner loops)`` of each candidate.
    options
        The tuning options.
    """
    law = tunable_law(options.controller, options.law_class)
    lim = gain_limits(vehicle, options.tilt_limit_deg)
    return np.array([law.image_violation(g, vehicle.m, options.gamma_max, lim["kp_max"], lim["gamma_delta_max"])
                     for g, _ in decoded])


def nni_design(vehicle: Vehicle, gains, options: TuneOptions):
    """The gains of the NI structure a candidate is certified as: its law's image (the gains themselves for a law of
    the structure, a filtered PD's NNI image), or the gains where the law has none.

    Parameters
    ----------
    vehicle
        The vehicle (its mass).
    gains
        A candidate's gains.
    options
        The tuning options.
    """
    image = gains.law.ni_image(gains, vehicle.m)
    return gains if image is None else image


def evaluate_details(vehicle: Vehicle, points: np.ndarray, options: TuneOptions, horizon_s: float,
                     inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS, *, full_report: bool = False,
                     prune_above: float | None = None) -> list[dict]:
    """What :func:`evaluate` computes, per candidate, as a dictionary.

    Keys: ``cost``, ``metrics`` (nominal), ``nominal_cost`` (worst of the
    nominal-objective scenarios), ``scenario_costs`` (robust, in the order of
    :func:`robust_scenarios`; ``None`` if not simulated), ``robust_settling_s``
    (the quantile, or ``None``), ``margins`` (``None`` if not computed).
    ``full_report`` simulates the robust set and computes the margins even for
    a candidate that fails earlier (for the report of the winner).

    ``prune_above`` (robust objective; the search's incumbent cost): a candidate
    whose nominal run and box corners already put its robust cost above this
    (:func:`robust_costs`) is not simulated on the random draws; its cost is then
    that lower bound (``robust_lower_bound`` is true), which is exact whenever the
    random draws settle before its second-slowest corner (they usually do: the heavy
    corners are the slowest).  It cannot become the incumbent either way, and the
    incumbent is always fully evaluated.
    """

    pts = np.atleast_2d(points)
    decoded = _decode_all(vehicle, pts, options, inner)
    outside = class_violations(vehicle, decoded, options)
    if np.any(outside > 0) and not full_report:
        # a filtered PD whose image leaves the class: ranked by how far, never simulated
        inside = np.flatnonzero(outside == 0)
        out = [{"cost": float(horizon_s * CLASS_PENALTY_HORIZONS * (1.0 + v)), "metrics": None, "nominal_cost": math.inf,
                "scenario_costs": None, "robust_settling_s": None, "margins": None, "margin_penalty": 0.0,
                "cost_without_margins": math.inf, "class_violation": float(v)} for v in outside]
        if len(inside):
            for b, d in zip(inside, evaluate_details(vehicle, pts[inside], options, horizon_s, inner)):
                out[b] = d
        return out
    base = simulation_options(options, horizon_s, inner)
    tilt_cap = options.tilt_limit_deg + TILT_SLACK_DEG if options.model == "full" else None
    xi0_norm = math.hypot(*base.xi0)
    worst = np.full(len(pts), -np.inf)
    nominal: list[Metrics] = []
    for k, scen in enumerate(scenario_options(options, base, vehicle)):
        res = simulate(vehicle, [g for g, _ in decoded], [scen.with_(inner=inn) for _, inn in decoded])
        _RUNS[0] += len(decoded)
        xy_end = res.xy[:, -1]
        for b, met in enumerate(res.metrics()):
            worst[b] = max(worst[b], _cost(met, xy_end[b], xi0_norm, horizon_s, tilt_cap))
            if k == 0:
                nominal.append(met)
    out = [{"cost": float(worst[b]), "metrics": nominal[b], "nominal_cost": float(worst[b]), "scenario_costs": None,
            "robust_settling_s": None, "margins": None, "margin_penalty": 0.0, "cost_without_margins": float(worst[b])}
           for b in range(len(pts))]
    if options.robust:
        todo = [b for b in range(len(pts)) if full_report or worst[b] < horizon_s]
        if todo:
            # the tracking objective's incumbent cost is not a settling time: nothing to prune against
            costs, pruned = robust_costs(vehicle, [decoded[b] for b in todo], options, horizon_s,
                                         prune_above=None if full_report or options.tracking else prune_above,
                                         nominal_costs=[worst[b] for b in todo], return_pruned=True)
            for b, c, cut in zip(todo, costs, pruned):
                allc = np.concatenate([[worst[b]], c])
                out[b]["scenario_costs"] = [float(worst[b])] + [None if np.isnan(v) else float(v) for v in c]
                out[b]["cost"] = robust_lower_bound(allc, horizon_s) if cut else robust_cost(allc, horizon_s)
                out[b]["robust_lower_bound"] = bool(cut)
                out[b]["robust_settling_s"] = out[b]["cost"] if out[b]["cost"] < horizon_s and not cut else None
                out[b]["cost_without_margins"] = out[b]["cost"]
    if options.require_margins:
        for b in range(len(pts)):
            if full_report or out[b]["cost"] < horizon_s:
                short, margins = margin_penalty(vehicle, nni_design(vehicle, decoded[b][0], options), decoded[b][1],
                                                options, horizon_s)
                out[b]["margins"] = margins
                if short > 0:
                    s_adm = out[b]["cost"]
                    if short >= 12.0 * horizon_s:  # unstable cascade
                        cost = short + s_adm
                    elif s_adm < horizon_s:
                        f = short / (1.0 + short) + 1e-3 * s_adm / horizon_s
                        cost = horizon_s + MARGIN_PENALTY_WIDTH_S * min(f, 0.999)
                    else:  # a failure already (full report): keep its rank
                        cost = s_adm
                    out[b]["margin_penalty"] = cost - s_adm
                    out[b]["margin_shortfall"] = short
                    out[b]["cost"] = cost
    if options.tracking:
        _add_tracking(vehicle, decoded, options, horizon_s, out, full_report)
    return out


# ----------------------------------------------------------------------------- tracking objective


def tracking_options(options: TuneOptions, inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS) -> SimOptions:
    """The run of the tracking objective: the nominal run's settings, started on the reference with its velocity
    (the law's state at rest for that start), the feedforward as asked, lasting to the window's end."""
    pos, vel, _ = options.reference.sample(0.0)
    return simulation_options(options, options.tracking_window[1], inner).with_(
        reference=options.reference, feedforward=options.feedforward, feedforward_lead_s=options.feedforward_lead_s,
        xi0=tuple(map(float, pos[0])), v0=tuple(map(float, vel[0])))


def tracking_cost(rms_m: float | None, settling_cost: float, horizon_s: float) -> float:
    """The tracking objective's cost of a candidate whose settling cost (margins included) is ``settling_cost``.

    Admissible (settling cost below the horizon, tracking run finite and not lost, ``rms_m`` not ``None``):
    ``horizon × rms / (rms + TRACKING_COST_SCALE_M)``, increasing in the RMS and below the horizon.  A candidate
    that fails the settling constraint keeps its settling penalty (at least the horizon); one whose tracking run is
    lost costs ``horizon + MARGIN_PENALTY_WIDTH_S + settling_cost``: above the designs that miss only the margins.

    Parameters
    ----------
    rms_m
        RMS tracking error over the window [m]; ``None``: the tracking run was lost (or not flown).
    settling_cost
        The candidate's cost under the settling objective.
    horizon_s
        The settling objective's horizon [s].
    """
    if settling_cost >= horizon_s:
        return float(settling_cost)
    if rms_m is None:
        return float(horizon_s + MARGIN_PENALTY_WIDTH_S + settling_cost)
    return float(horizon_s * rms_m / (rms_m + TRACKING_COST_SCALE_M))


def tracking_rms_of_cost(cost: float, horizon_s: float) -> float | None:
    """The RMS tracking error [m] of an admissible tracking cost (:func:`tracking_cost` inverted), else ``None``."""
    if not cost < horizon_s:
        return None
    return float(TRACKING_COST_SCALE_M * cost / (horizon_s - cost))


def _add_tracking(vehicle: Vehicle, decoded: list, options: TuneOptions, horizon_s: float, out: list[dict],
                  full_report: bool) -> None:
    """Fly the tracking run of every candidate that is otherwise admissible (every one with ``full_report``) in one
    batched call; set ``tracking_rms_m``, ``tracking_max_m``, ``settling_cost`` and the cost (:func:`tracking_cost`)."""
    todo = [b for b in range(len(out)) if full_report or out[b]["cost"] < horizon_s]
    for d in out:
        d.update(settling_cost=d["cost"], tracking_rms_m=None, tracking_max_m=None)
    if todo:
        with np.errstate(all="ignore"):
            res = simulate(vehicle, [decoded[b][0] for b in todo],
                           [tracking_options(options, decoded[b][1]) for b in todo])
        _RUNS[0] += len(todo)
        for i, (b, met, xy) in enumerate(zip(todo, res.metrics(), res.xy)):
            if met.diverged or not np.all(np.isfinite(xy)):
                continue
            track = res[i].tracking(options.tracking_window)
            out[b]["tracking_rms_m"], out[b]["tracking_max_m"] = track.tracking_rms_m, track.tracking_max_m
    for d in out:
        d["cost"] = tracking_cost(d["tracking_rms_m"], d["settling_cost"], horizon_s)


# ----------------------------------------------------------------------------- robust objective


_SCENARIO_CACHE: dict[tuple, list] = {}

#: Runs simulated by :func:`evaluate_details` since the process started (:func:`simulations_run`).
_RUNS = [0]


def simulations_run() -> int:
    """Number of single runs simulated by the objective so far (nominal and robust scenarios)."""
    return _RUNS[0]


def robust_scenarios(vehicle: Vehicle, options: TuneOptions) -> list:
    """The fixed tuning set of these options (:func:`nniquad.tuning.robust_scenarios.tuning_scenarios`), cached.

    The ranges are the Monte Carlo defaults with the position noise of
    :attr:`TuneOptions.robust_noise_range_m` and the wind of
    :attr:`TuneOptions.robust_wind_fraction_range`.  The first entry is the nominal
    scenario (simulated by the nominal objective); the same list, and so the
    same plants, noise sequences, winds and start points, is used for every
    candidate (common random numbers).
    """

    key = (vehicle, options.scenario_seed, options.roa_radius_m, options.noise_sigma_m, options.robust_noise_range_m,
           options.robust_wind_fraction_range)
    if key not in _SCENARIO_CACHE:
        _SCENARIO_CACHE.clear()
        ranges = DEFAULT_RANGES.with_(noise_sigma_m=options.robust_noise_range_m,
                                      wind_weight_fraction=options.robust_wind_fraction_range)
        _SCENARIO_CACHE[key] = tuning_scenarios(vehicle, seed=options.scenario_seed, roa_radius_m=options.roa_radius_m,
                                                ranges=ranges, noise_sigma_m=options.noise_sigma_m)
    return _SCENARIO_CACHE[key]


#: Largest number of runs in one robust ``simulate`` call: the per-run noise inputs of a 14 s run take
#: about 0.55 MB, so 240 runs hold about 130 MB.
ROBUST_BATCH_RUNS = 240


def robust_costs(vehicle: Vehicle, designs: list, options: TuneOptions, horizon_s: float, *,
                 prune_above: float | None = None, nominal_costs: list[float] | None = None,
                 return_pruned: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """:func:`_cost` of every design on every perturbed scenario of the tuning set (the nominal one excluded).

    A scenario's settling is measured from the static equilibrium the law holds under
    its wind (:meth:`nniquad.laws.base.ControlLaw.wind_equilibrium`: the setpoint for a
    law with integral action, whose static stiffness is infinite), in the band of 2 %
    of the nominal ‖ξ_h(0)‖.  The Monte Carlo verdict measures to the setpoint; the
    tuner keeps the wind equilibrium so that a law without integral action, which
    cannot hold the setpoint against a steady wind, is still ranked by how fast it
    settles (its steady offset is the law's static stiffness, not a tuning matter); the
    honest-settling rule and the altitude cap are those of the nominal cost; the
    actual tilt may exceed the limit by :data:`ROBUST_TILT_SLACK_DEG` (the nominal
    run: by ``TILT_SLACK_DEG``, 1°).  The issue's requirement on every scenario is
    to settle without altitude loss or divergence; the tilt overshoot of a
    perturbed attitude loop is not a failure of the flight, and capping it at 1°
    in the slow-motor corners made every design slow (docs/notes/tuning.md).  All designs × scenarios run in as few batched
    :func:`nniquad.sim.simulate` calls as memory allows (:data:`ROBUST_BATCH_RUNS`).

    Parameters
    ----------
    designs
        ``(Gains, InnerLoopGains)`` pairs.

    Notes
    -----
    The corners run first; the other scenarios only for designs that pass every
    corner (a design that fails one pays the penalty whatever the rest give), so
    their entries stay ``nan`` otherwise.  With ``prune_above`` (and the designs'
    ``nominal_costs``), also not for a design whose nominal run and corners put
    :func:`robust_lower_bound` above it (it cannot beat that cost).

    Returns
    -------
    ndarray (len(designs), n_scenarios - 1)
        The costs (``nan``: not simulated).
    ndarray of bool (len(designs),), with ``return_pruned``
        Which designs were pruned by ``prune_above``.
    """

    scen = robust_scenarios(vehicle, options)[1:]
    out = np.full((len(designs), len(scen)), np.nan)
    # stage 1: the corners (where failures happen); stage 2: the rest, only for designs that pass every corner
    corners = [i for i, s in enumerate(scen) if s.label.startswith("corner")]
    rest = [i for i in range(len(scen)) if i not in corners]
    _simulate_scenarios(vehicle, designs, options, horizon_s, scen, [(d, s) for d in range(len(designs))
                                                                    for s in corners], out)
    alive = [d for d in range(len(designs)) if np.all(out[d, corners] < horizon_s)]
    pruned = np.zeros(len(designs), dtype=bool)
    if prune_above is not None and nominal_costs is not None:
        for d in alive:
            pruned[d] = robust_lower_bound(np.concatenate([[nominal_costs[d]], out[d]]), horizon_s) > prune_above
        alive = [d for d in alive if not pruned[d]]
    _simulate_scenarios(vehicle, designs, options, horizon_s, scen, [(d, s) for d in alive for s in rest], out)
    return (out, pruned) if return_pruned else out


def _simulate_scenarios(vehicle: Vehicle, designs: list, options: TuneOptions, horizon_s: float, scen: list,
                        jobs: list[tuple[int, int]], out: np.ndarray) -> None:
    """Fill ``out[d, s]`` with :func:`_cost` for the ``(design, scenario)`` jobs, in batched calls."""

    # the nominal run keeps limit + 1 deg; a perturbed plant (slow motor, low attitude gain) may overshoot its
    # tilt command, which the Monte Carlo verdict does not count: guarded only against a flip-like excursion
    tilt_cap = options.tilt_limit_deg + ROBUST_TILT_SLACK_DEG
    for lo in range(0, len(jobs), ROBUST_BATCH_RUNS):
        chunk = jobs[lo:lo + ROBUST_BATCH_RUNS]
        pairs = [scen[s].params(vehicle, designs[d][0], designs[d][1], horizon_s, options.tilt_limit_deg,
                                motor_lag=options.motor_lag, rate_hz=options.rate_hz) for d, s in chunk]
        with np.errstate(all="ignore"):  # the perturbed scenarios read the position options.delay_samples late
            res = simulate(None, None, [o.with_(delay_samples=options.delay_samples) for o, _ in pairs],
                           params=[p for _, p in pairs])
        _RUNS[0] += len(pairs)
        xy, phi, theta, z = res.xy, res.phi, res.theta, res.z_ned  # computed once (properties)
        for i, (d, s) in enumerate(chunk):
            eq = np.asarray(scen[s].equilibrium_m(vehicle, designs[d][0]))
            rel = xy[i] - eq
            with np.errstate(all="ignore"):
                met = compute_metrics(res.t, xy[i], phi=phi[i], theta=theta[i], tilt_limit_deg=options.tilt_limit_deg,
                                      z=z[i], z_ref=0.0)
                st = float(settling_time_batch(res.t, rel[None], BAND_FRACTION, XI0_NORM_M)[0])
            met = replace(met, settling_s=st if math.isfinite(st) and not met.diverged else None)
            start = max(math.hypot(*scen[s].xi0_m), BAND_FRACTION * XI0_NORM_M)
            out[d, s] = _cost(met, rel[-1], start, horizon_s, tilt_cap)


def robust_cost(costs: np.ndarray, horizon_s: float, quantile: float = ROBUST_QUANTILE) -> float:
    """The robust cost of one candidate from its scenario costs (:func:`_cost` each).

    Every scenario admissible (cost below the horizon): the ``quantile`` of the
    settling times (``numpy.quantile``, linear interpolation).  Otherwise a
    ranked penalty above every admissible cost: the worst scenario's penalty
    plus one horizon per further failing scenario.
    """
    c = np.asarray(costs, float)
    c = c[~np.isnan(c)]  # scenarios not simulated after a failed corner (robust_costs)
    bad = c >= horizon_s
    if np.any(bad) or not np.all(np.isfinite(c)):
        return float(np.max(c) + horizon_s * (np.count_nonzero(bad) - 1))
    return float(np.quantile(c, quantile))


def robust_lower_bound(costs: np.ndarray, horizon_s: float, quantile: float = ROBUST_QUANTILE) -> float:
    """A lower bound of :func:`robust_cost` when some scenarios (``nan``) are not simulated yet.

    Every cost is at least 0 and the quantile is non-decreasing in each cost, so the
    costs with the missing ones set to 0 bound it from below; with the default
    quantile it depends on the two largest costs only, so it is exact when no missing
    scenario would exceed the second-largest known one.
    """
    c = np.asarray(costs, float)
    return robust_cost(np.where(np.isnan(c), 0.0, c), horizon_s, quantile)


# ----------------------------------------------------------------------------- margins


#: Width [s] of the cost window ``[horizon, horizon + width)`` of the designs that miss only the margins.
MARGIN_PENALTY_WIDTH_S = 0.5


def margin_penalty(vehicle: Vehicle, gains, inner: InnerLoopGains, options: TuneOptions,
                   horizon_s: float) -> tuple[float, dict | None]:
    """Penalty of a design that misses the classical-margin requirement, and its margins.

    Only a design that is otherwise admissible (cost ``s < horizon``) is checked
    (lazily: a linearisation and two fast margin evaluations, ~25 ms).  A design
    that misses the requirement gets the cost
    ``horizon + MARGIN_PENALTY_WIDTH_S × f`` with ``f = shortfall/(1 + shortfall)``
    (:func:`nniquad.analysis.fast_margins.margin_shortfall`, plus a 1e-3 × s/horizon
    tie-break): above every admissible cost, ranked by how far it misses, and below
    the simulation failures (whose penalties start at ``horizon`` plus a settling
    time: the smallest seen is several seconds), so that when no design can meet
    the requirement the search still ends on the best attainable margins of a design
    that settles.  The returned penalty is that cost minus ``s``; an unstable or
    non-linearisable cascade costs ``12 horizon``.
    """

    try:
        margins = design_margins(vehicle, gains, inner, tilt_limit_deg=options.tilt_limit_deg, rate_hz=options.rate_hz)
    except CascadeError:
        return 12.0 * horizon_s, None
    short = margin_shortfall(margins, include_pm=options.require_pm)
    if not math.isfinite(short):
        return 12.0 * horizon_s, margins
    return short, margins
