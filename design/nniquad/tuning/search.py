"""The search stages: the initial design (Sobol, with a share on the sector-bound face), the sweep and the starts.

The optimiser that follows the sweep is in :mod:`nniquad.tuning.optimizers`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from nniquad.analysis.lmi.reduced_region import certified_reach
from nniquad.analysis.reduced_loop import reduced_loop
from nniquad.model.vehicle import Vehicle
from nniquad.sim.verdicts import Metrics
from nniquad.tuning.coordinates import decode, search_box, tunable_law
from nniquad.tuning.objective import evaluate, nni_design, scenario_options, simulation_options
from nniquad.tuning.tune_options import SECTOR_FACE_SHARE, TuneOptions

# ----------------------------------------------------------------------------- search


@dataclass
class Candidate:
    """One evaluated point: coordinates, cost [s] and nominal metrics."""

    q: np.ndarray
    cost: float
    metrics: Metrics
    reach_m: float | None = None


class SearchState:
    """Bookkeeping shared by the stages: evaluation counts, the reach cache, progress."""

    def __init__(self, vehicle: Vehicle, options: TuneOptions, horizon_s: float,
                 progress: Callable[[str], None] | None) -> None:
        self.vehicle, self.options, self.horizon_s = vehicle, options, horizon_s
        self.lo, self.hi = search_box(options, vehicle=vehicle)
        self.n_sim = 0
        self.n_lmi = 0
        self._reach: dict[tuple, float] = {}
        #: The optimiser's incumbent cost while it runs (:func:`nniquad.tuning.optimizers.minimise`), else None.
        self.prune_above: float | None = None
        self.progress = progress or (lambda msg: None)

    def evaluate(self, pts: np.ndarray, screen: bool = False) -> list[Candidate]:
        """Candidates of the points (clipped to the box); ``screen``: on the nominal run only.

        The sweep screens (a robust candidate costs the 20 tuning scenarios, a
        nominal one a single run); its best points are evaluated again in full
        before the optimiser starts from them.  While the optimiser runs,
        :attr:`prune_above` holds its incumbent's cost: a robust candidate whose
        nominal run and corners already cost more is not run on the random draws
        (:func:`nniquad.tuning.objective.evaluate_details`).
        """
        pts = np.clip(np.atleast_2d(pts), self.lo, self.hi)
        options = self.options
        if screen and (options.robust or options.require_margins):
            options = replace(options, objective="nominal", require_margins=False, require_pm=False)
        cost, mets = evaluate(self.vehicle, pts, options, self.horizon_s,
                              prune_above=None if screen else self.prune_above)
        self.n_sim += len(pts) * len(scenario_options(self.options, simulation_options(self.options, 1.0),
                                                        self.vehicle))
        return [Candidate(q.copy(), float(c), m) for q, c, m in zip(pts, cost, mets)]

    def admissible(self, cand: Candidate) -> bool:
        """Certified reach check (cached); always true with ``roa_radius_m = 0``."""
        if self.options.roa_radius_m <= 0:
            return True
        law = tunable_law(self.options.controller, self.options.law_class)
        key = tuple(np.round(cand.q[:law.dims], 9))
        if key not in self._reach:
            gains, _ = decode(cand.q, self.vehicle.m, self.options.gamma_max, controller=self.options.controller,
                              law_class=self.options.law_class)
            gains = nni_design(self.vehicle, gains, self.options)  # a filtered PD in a class: its NNI image
            self._reach[key] = certified_reach(reduced_loop(self.vehicle, gains), self.options.tilt_limit_deg)
            self.n_lmi += 1
        cand.reach_m = self._reach[key]
        return cand.reach_m >= self.options.roa_radius_m


def _sobol(n: int, lo: np.ndarray, hi: np.ndarray, seed: int | np.random.Generator) -> np.ndarray:
    from scipy.stats import qmc

    m = max(1, int(math.ceil(math.log2(max(n, 2)))))
    pts = qmc.Sobol(d=len(lo), scramble=True, seed=seed).random_base2(m)[:n]
    return lo + pts * (hi - lo)


def initial_design(n: int, lo: np.ndarray, hi: np.ndarray, seed: int, sector_face: bool = True) -> np.ndarray:
    """The global sweep's points: a Sobol set in the box, and a share of them on the sector-bound face.

    The fastest designs sit on the face ``u = 0`` (γ = γ_max) of the box: the
    sector bound is the constraint that limits the gains.  A Sobol set in the
    box puts no point exactly on a face and only a few within a small distance
    of it (with 256 points, about 3 within 1 % of the ``u`` range), so with the
    honest settling rule a quick sweep found no settling candidate at all.
    :data:`SECTOR_FACE_SHARE` of the points are therefore a second, independent
    Sobol set over the other coordinates with ``u = lo[1]``.

    Parameters
    ----------
    n
        Number of points.
    lo, hi
        The search box (:func:`search_box`); coordinate 1 is ``u``.
    seed
        Seed of the scrambling (the face set uses an independent stream of it).
    sector_face
        Place the share on the face (the NNI law's ``paper`` class,
        :attr:`nniquad.tuning.coordinates.TunableLaw.sector_face`); ``False`` for a law
        without a sector bound (PD, the ``cascade`` class): all points are one
        Sobol set in the box.

    Returns
    -------
    ndarray (n, d)
        The box points first, then the face points.
    """
    n_face = int(round(SECTOR_FACE_SHARE * n)) if sector_face else 0
    box = _sobol(n - n_face, lo, hi, seed)
    face = _sobol(n_face, lo, hi, np.random.default_rng([seed, 1])) if n_face else np.empty((0, len(lo)))
    face[:, 1] = lo[1]
    return np.vstack([box, face])


def global_sweep(search: SearchState, n: int, seed: int, batch: int = 256) -> list[Candidate]:
    law = tunable_law(search.options.controller, search.options.law_class)
    pts = initial_design(n, search.lo, search.hi, seed, sector_face=law.sector_face)
    out: list[Candidate] = []
    for i in range(0, len(pts), batch):
        out += search.evaluate(pts[i : i + batch], screen=True)
        search.progress(f"sweep {min(i + batch, len(pts))}/{len(pts)} points")
    out.sort(key=lambda c: c.cost)
    return out


def optimiser_starts(search: SearchState, ranked: list[Candidate], k: int, max_checks: int = 60) -> list[Candidate]:
    """The best ``k`` admissible sweep points that are not near each other (10 % of the box apart)."""
    chosen: list[Candidate] = []
    for cand in ranked[:max_checks]:
        if any(np.max(np.abs(cand.q - c.q) / (search.hi - search.lo)) < 0.1 for c in chosen):
            continue
        if search.admissible(cand):
            chosen.append(cand)
        if len(chosen) == k:
            break
    return chosen
