"""The tuner's local-global stage: BIPOP-CMA-ES (pycma) or MADS (NOMAD 4), fed with batches of candidates.

Both backends see the same problem: the search coordinates normalised to the
unit box ``x = (q - lo) / (hi - lo)``, a cost that is one batched simulation
per block of candidates (``search.evaluate``), and the certified-reach check
applied lazily (only to a candidate that would become the incumbent; an
inadmissible one is told to the optimiser at ``cost + horizon``, above every
admissible settling time).  Every evaluation counts in ``search.n_sim`` (the
search does the counting), and every candidate handed to ``evaluate`` comes in
a batch of several.

``"cma"``
    CMA-ES (Hansen & Ostermeier, Evol. Comput. 9(2), 2001) with the BIPOP
    restart schedule (Hansen, GECCO BBOB workshop 2009): a first run with the
    default population from the best sweep point, then alternately IPOP runs
    (population doubled each time, Auger & Hansen, CEC 2005) from the other
    distinct sweep starts (then from uniform random points) and small-population
    runs with a smaller step size from the incumbent, the small ones kept
    within the evaluations the large ones used.  The first run may spend
    :data:`CMA_FIRST_RUN_SHARE` of the evaluations (at least
    :data:`CMA_FIRST_RUN_MIN_GENERATIONS` generations), so that on a budget
    of that size the local regime gets the rest.  The small runs search in
    the frame the latest large run learned (:func:`learned_frame`, the shape
    of its covariance; :data:`SMALL_RUNS_IN_LEARNED_FRAME`), not in the unit
    box's axes: restarted with the identity covariance they spent their
    evaluations learning a narrow valley's orientation again.  One generation
    is one batch.
``"nomad"``
    NOMAD 4 (Le Digabel, ACM TOMS 37(4), 2011), the Mesh Adaptive Direct
    Search (Audet & Dennis, SIAM J. Optim. 17(1), 2006) with ORTHO 2N poll
    directions, search and poll points merged into one block
    (``MEGA_SEARCH_POLL``) so that a block is one batched simulation; a run that
    ends (its frame reached ``MIN_FRAME_SIZE``) is restarted from the next
    sweep start, then from the best of a batch of random points, with the
    evaluations left.

Both are seeded from the tuner's seed and draw from nothing else (the CMA
samples come from a ``numpy`` generator of that seed, not the global state;
NOMAD's process-wide generator is reset and seeded before every run), so the
same seed gives the same result.  NOMAD's ORTHO 2N poll turns out to be
deterministic given x0 (measured: seeds 5, 7 and 123 take the same path), so
there the seed acts through the Sobol sweep (the starts) and the random
restart points.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from nniquad.errors import NniquadError
from nniquad.tuning.tune_options import OPTIMIZERS

if TYPE_CHECKING:  # pragma: no cover
    from nniquad.tuning.search import Candidate, SearchState

__all__ = ["minimise", "OPTIMIZERS", "CMA_SIGMA0", "MIN_STEP", "CMA_FIRST_RUN_SHARE", "CMA_FIRST_RUN_MIN_GENERATIONS",
           "default_population", "first_run_evaluations", "learned_frame", "SMALL_RUNS_IN_LEARNED_FRAME"]

#: Initial CMA step size and NOMAD frame size, as a fraction of the box in every coordinate.
CMA_SIGMA0 = 0.2

#: A run ends when its step size (CMA ``tolx``) or frame (NOMAD ``MIN_FRAME_SIZE``) is below this box
#: fraction: 1e-4 of ln kp's range moves kp by 0.08 %, far below what the settling time resolves.
MIN_STEP = 1e-4

#: NOMAD's seeds are drawn below this: its set-up time grows with the seed's value (about 1 s at 1e7).
NOMAD_SEED_MAX = 100_000

#: CMA runs stop when the costs of recent generations differ by less than this [s] (``tolfun``).
COST_TOL_S = 1e-4

#: Share of the evaluations the first (large-population) CMA run may spend; BIPOP's local runs from the
#: incumbent then get the rest.  Without a cap the first run spent the whole robust-default budget (400
#: evaluations in 6 coordinates) before its step size converged, no local run ever started, and five seeds on
#: the paper's vehicle ended 11.2 % apart (3.10-3.45 s); with half of it, 3.7 % (3.11-3.22 s) (docs/notes/tuning.md).
CMA_FIRST_RUN_SHARE = 0.5

#: ... but never fewer generations of the default population than this: on a small budget (``quick``, 60
#: robust evaluations) a first run cut to half (three generations) could not leave the sweep's start, and
#: Crazyflie 2's quick certificate found no gain set that settles; such a budget stays with the first run, as
#: before.  20 generations also held the reduced model's quick tune (200 evaluations in 3 coordinates) at 140
#: instead of 100 for its first run, and five seeds spread 2.37 % instead of 0.86 % (docs/notes/tuning.md).
CMA_FIRST_RUN_MIN_GENERATIONS = 10

#: BIPOP's small runs start in the coordinates ``x = x_inc + F y`` of :func:`learned_frame` (``F`` from the latest
#: large run), with the identity covariance in ``y``.  Restarted in the unit box's axes instead, they lost the
#: orientation of the robust objective's narrow valley, and five seeds of the robust default on the paper's
#: vehicle ended 3.7 % apart (3.11-3.22 s); in the learned frame, 0.62 % (3.113-3.132 s) (docs/notes/tuning.md).
SMALL_RUNS_IN_LEARNED_FRAME = True


class _Tracker:
    """The shared bookkeeping: unit-box maps, the lazy reach check, the incumbent, the evaluation count."""

    def __init__(self, search: "SearchState", starts: list["Candidate"], max_evals: int) -> None:
        self.search = search
        self.lo, self.width = np.asarray(search.lo, float), np.asarray(search.hi, float) - np.asarray(search.lo, float)
        self.max_evals = int(max_evals)
        self.evals = 0
        self.best: "Candidate | None" = None
        for c in starts:  # the starts are admissible (``optimiser_starts`` checked them)
            if self.best is None or c.cost < self.best.cost:
                self.best = c
        self.run_bests: list["Candidate"] = []
        # NOMAD evaluates its x0 alone first: a start's cost is known, so that block costs no simulation
        self.known = {self._key(self.to_unit(c.q)): c.cost for c in starts}

    @staticmethod
    def _key(x: np.ndarray) -> tuple:
        return tuple(np.round(np.asarray(x, float), 12))

    @property
    def left(self) -> int:
        return self.max_evals - self.evals

    def to_unit(self, q: np.ndarray) -> np.ndarray:
        return np.clip((np.asarray(q, float) - self.lo) / self.width, 0.0, 1.0)

    def to_q(self, x: np.ndarray) -> np.ndarray:
        return self.lo + np.clip(np.asarray(x, float), 0.0, 1.0) * self.width

    def costs(self, xs: np.ndarray) -> list[float]:
        """Simulate a batch (unit-box points) and return the costs to tell, penalising inadmissible incumbents."""
        xs = np.atleast_2d(xs)
        if len(xs) == 1 and self._key(xs[0]) in self.known:
            return [self.known[self._key(xs[0])]]
        # a candidate that cannot beat the incumbent need not run every scenario (its cost is then a lower bound)
        self.search.prune_above = None if self.best is None else self.best.cost
        cands = self.search.evaluate(self.to_q(xs))
        self.evals += len(cands)
        costs = [float(c.cost) for c in cands]
        for i in np.argsort(costs, kind="stable"):
            if self.best is not None and costs[i] >= self.best.cost:
                break
            if self.search.admissible(cands[i]):
                self.best = cands[i]
                break
            # would have become the incumbent without a certified reach: rank it above every admissible settling
            costs[i] += self.search.horizon_s
        return costs

    def end_run(self) -> None:
        if self.best is not None and all(self.best is not c for c in self.run_bests):
            self.run_bests.append(self.best)


def minimise(search: "SearchState", starts: list["Candidate"], *, method: str, max_evals: int,
             seed: int) -> list["Candidate"]:
    """Minimise ``search``'s cost from the sweep's starts with one of :data:`OPTIMIZERS`.

    Parameters
    ----------
    search
        Provides ``lo``, ``hi`` (the box), ``evaluate(points) -> list[Candidate]`` (one batch),
        ``admissible(candidate) -> bool``, ``horizon_s`` (the penalty) and ``progress(str)``;
        its ``prune_above`` attribute is set to the incumbent's cost before each batch
        (a candidate that cannot beat it may be evaluated in part) and cleared at the end.
    starts
        Admissible evaluated points, best first (the first starts the first run).
    method
        ``"cma"`` (BIPOP-CMA-ES) or ``"nomad"`` (MADS); module docstring.
    max_evals
        Candidates to evaluate at most (the last batch is cut to fit).
    seed
        Seed of every random choice.

    Returns
    -------
    list of Candidate
        The incumbent after each run (admissible), best first; the starts' best if nothing improved.

    Raises
    ------
    NniquadError
        Unknown ``method`` or no start.
    """
    if method not in OPTIMIZERS:
        raise NniquadError(f"optimizer must be one of {', '.join(OPTIMIZERS)}, got {method!r}")
    if not starts:
        raise NniquadError("the optimiser needs at least one start")
    starts = sorted(starts, key=lambda c: c.cost)
    tr = _Tracker(search, starts, max_evals)
    try:
        (_cma if method == "cma" else _nomad)(tr, starts, seed)
    finally:
        search.prune_above = None  # evaluations outside the optimiser (starts, reports) are never pruned
    tr.end_run()
    return sorted(tr.run_bests, key=lambda c: c.cost)


# ----------------------------------------------------------------------------- CMA-ES


def _next_x0(tr: _Tracker, starts: list["Candidate"], used: list[int], rng: np.random.Generator) -> np.ndarray:
    """The next sweep start not used yet, then uniform random points of the box."""
    if used[0] < len(starts):
        used[0] += 1
        return tr.to_unit(starts[used[0] - 1].q)
    return rng.random(len(tr.lo))


def default_population(dims: int) -> int:
    """CMA-ES's default population ``4 + ⌊3 ln d⌋`` in ``dims`` coordinates."""
    return 4 + int(3 * math.log(dims))


def first_run_evaluations(max_evals: int, dims: int) -> int:
    """Evaluations the first CMA-ES run may spend: :data:`CMA_FIRST_RUN_SHARE` of ``max_evals``, but at least
    :data:`CMA_FIRST_RUN_MIN_GENERATIONS` generations of the :func:`default_population`."""
    return max(int(CMA_FIRST_RUN_SHARE * max_evals), CMA_FIRST_RUN_MIN_GENERATIONS * default_population(dims))


def learned_frame(es: "object") -> np.ndarray | None:
    """A Cholesky factor of the shape a CMA-ES run learned: its covariance without the step size.

    The shape is scaled to a unit geometric mean of its eigenvalues, so that a
    step size in the frame moves a point by about as much (in volume) as the
    same step size in the unit box: BIPOP's schedule of small step sizes keeps
    its meaning.

    Parameters
    ----------
    es
        A ``cma.CMAEvolutionStrategy`` (its ``sm.C`` and ``sigma_vec.scaling`` are read).

    Returns
    -------
    ndarray (d, d) or None
        Lower-triangular ``F`` with ``F Fᵀ`` the scaled shape; ``None`` when the
        shape is not finite or not positive definite to 1e-12 of its largest
        eigenvalue (the small run then searches in the unit box's axes).
    """
    C = np.asarray(es.sm.C, float)
    scaling = np.broadcast_to(np.asarray(getattr(es.sigma_vec, "scaling", 1.0), float), (C.shape[0],))
    C = C * np.outer(scaling, scaling)
    if not np.all(np.isfinite(C)):
        return None
    ev = np.linalg.eigvalsh(0.5 * (C + C.T))
    if ev[0] <= 1e-12 * ev[-1]:
        return None
    return np.linalg.cholesky(C / math.exp(float(np.mean(np.log(ev)))))


def _cma(tr: _Tracker, starts: list["Candidate"], seed: int) -> None:
    import cma

    d = len(tr.lo)
    rng = np.random.default_rng([seed, 0xC3A])
    lam0 = default_population(d)
    used = [0]
    n_large, evals_large, evals_small, run = 0, 0, 0, 0
    first_cap = first_run_evaluations(tr.left, d)
    frame: np.ndarray | None = None  # the latest large run's learned shape (learned_frame)
    while tr.left >= 2:
        centre = None
        if run == 0 or evals_small >= evals_large:
            regime = "large"
            lam, sigma, x0 = lam0 * 2**n_large, CMA_SIGMA0, _next_x0(tr, starts, used, rng)
            n_large += 1
        else:  # BIPOP's local regime: smaller population and step size, here from the incumbent
            regime = "small"
            u = rng.random()
            lam = max(2, int(lam0 * (0.5 * 2 ** (n_large - 1)) ** (rng.random() ** 2)))
            sigma, x0 = CMA_SIGMA0 * 10.0 ** (-2.0 * u), tr.to_unit(tr.best.q)
            if SMALL_RUNS_IN_LEARNED_FRAME and frame is not None:
                # in the coordinates the large run learned: y = 0 is the incumbent, x = x_inc + F y
                centre, x0 = x0, np.zeros(d)
        lam = min(lam, tr.left)
        opts = {"popsize": lam, "seed": int(rng.integers(1, 2**31 - 1)), "verbose": -9,
                "verb_log": 0, "verb_disp": 0, "maxfevals": first_cap if run == 0 else tr.left, "tolx": MIN_STEP,
                "tolfun": COST_TOL_S, "tolfunhist": COST_TOL_S, "randn": lambda *shape: rng.standard_normal(shape)}
        if centre is None:
            opts["bounds"] = [0.0, 1.0]
            x0 = np.clip(x0, 0.0, 1.0)
        es = cma.CMAEvolutionStrategy(x0, sigma, opts)
        # a framed point outside the unit box is clipped into it by the tracker (to_q), as every other point is
        to_x = (lambda ys: np.asarray(ys, float)) if centre is None else \
            (lambda ys, c=centre, F=frame: c + np.asarray(ys, float) @ F.T)
        before = tr.evals
        gen = 0
        while not es.stop() and tr.left >= 2:
            xs = es.ask()
            if len(xs) > tr.left:
                break  # cma cannot take a cut generation; the remaining budget goes unused
            es.tell(xs, tr.costs(to_x(np.array(xs))))
            gen += 1
            tr.search.progress(f"cma restart {run} ({regime}, pop {lam}) gen {gen}: best {tr.best.cost:.4g} s, "
                               f"{tr.evals} evals")
        spent = tr.evals - before
        if regime == "large":
            evals_large += spent
            frame = learned_frame(es) if gen > 0 else frame
        else:
            evals_small += spent
        tr.end_run()
        run += 1
        if spent == 0:
            break


# ----------------------------------------------------------------------------- NOMAD


def _nomad(tr: _Tracker, starts: list["Candidate"], seed: int) -> None:
    try:
        import PyNomad
    except ImportError:
        raise NniquadError("optimizer 'nomad' needs NOMAD's Python interface: pip install 'PyNomadBBO>=4.4,<5' "
                           "(the dev extra has it), or use --optimizer cma") from None

    d = len(tr.lo)
    rng = np.random.default_rng([seed, 0x40AD])
    used = [0]
    run = 0
    block_size = 4 * d + 8  # the poll (2n with ORTHO 2N) plus the search points of one iteration
    failure: list[BaseException] = []

    while tr.left >= 2:
        if used[0] < len(starts):
            x0 = _next_x0(tr, starts, used, rng)
        else:  # starts used up: restart from the best of a batch of random points (NOMAD's x0 is known then)
            xs = rng.random((min(2 * d, tr.left), d))
            costs = tr.costs(xs)
            x0 = xs[int(np.argmin(costs))]
            tr.known[tr._key(x0)] = float(min(costs))
            if tr.left < 2:
                break
        blocks = [0]

        def bb_block(block, run=run, blocks=blocks) -> list[bool]:
            n = block.size()
            if failure:
                return [False] * n
            try:
                k = min(n, tr.left) if tr.left >= 2 else 0  # no batch of one at the end of the budget
                pts = [block.get_x(i) for i in range(n)]
                xs = np.array([[p.get_coord(j) for j in range(d)] for p in pts[:k]])
                costs = tr.costs(xs) if k else []
                for p, c in zip(pts, costs):
                    p.setBBO(repr(float(c)).encode("utf-8"))
                blocks[0] += 1
                tr.search.progress(f"nomad run {run} block {blocks[0]}: best {tr.best.cost:.4g} s, {tr.evals} evals")
                return [True] * k + [False] * (n - k)
            except BaseException as exc:  # a fault (or Ctrl-C) inside NOMAD's callback: re-raised below
                failure.append(exc)
                return [False] * n

        nomad_seed = int(rng.integers(0, NOMAD_SEED_MAX))
        params = ["BB_OUTPUT_TYPE OBJ", f"MAX_BB_EVAL {tr.left}", f"BB_MAX_BLOCK_SIZE {block_size}",
                  "DISPLAY_DEGREE 0", f"SEED {nomad_seed}", "MEGA_SEARCH_POLL yes",
                  "DIRECTION_TYPE ORTHO 2N", "NB_THREADS_PARALLEL_EVAL 1",
                  f"INITIAL_FRAME_SIZE * {CMA_SIGMA0}", f"MIN_FRAME_SIZE * {MIN_STEP}"]
        before = tr.evals
        # NOMAD's generator is process-wide and the SEED parameter alone does not restart it: without
        # this the first run in a process takes another path than a later one with the same seed
        PyNomad.resetRandomNumberGenerator()
        PyNomad.setSeed(nomad_seed)
        PyNomad.optimize(bb_block, [float(v) for v in x0], [0.0] * d, [1.0] * d, params)
        if failure:
            raise failure[0]
        tr.end_run()
        run += 1
        if tr.evals == before:
            break
