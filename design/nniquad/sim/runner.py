"""The one simulation entry point, :func:`simulate`, and the batched runner behind it.

:func:`simulate` runs one or many parameter sets -- gain sets, option sets
(e.g. inner-loop gains or noise seeds per run) or ready :class:`SimParams`
(perturbed plants) -- in one batched call (a serial CasADi ``map`` over the
runs of each thread, one thread per usable core) and returns one
:class:`nniquad.sim.results.SimulationResult`.  The simulate command, the
tuner, the Monte Carlo study, the certificate's performance runs, the report
and the notebooks all call it.

Integration: ``K = output_dt/dt`` RK4 steps per output sample are one compiled
function (:func:`nniquad.sim.models.chunk_function`), ``mapaccum`` over the
samples of a segment and ``map`` over the runs; a run is cut into about 20
segments (calls into CasADi), which drive the progress callback.  The
exogenous input (noise, sample flag, gust) is held constant over a step.

Controller sampling (:attr:`SimOptions.controller_sampling`): ``"continuous"``,
``"held"`` (the measurement sampled and held at ``noise_rate_hz``, the controller
state integrated continuously on it) or ``"discrete"`` (the law in discrete
time at that rate, its command held over the period: for NNI what
:class:`nniquad.control.discrete.DiscreteNNI` runs and ``nniquad export`` writes;
the PD laws likewise, :mod:`nniquad.sim.models`).

Accuracy at the default step of 1 ms (``tests/test_simulate.py``): the linear
model agrees with the matrix exponential to ~2e-10 m over 30 s; the full model
with DOP853 (``solve_ivp``, rtol 1e-11) to ~3e-6 m over 4 s (~2e-5 m with motor
lag: saturation kinks cap RK4 near first order).  Before any work every run's
step is checked against every pole it has (:func:`nniquad.sim.step_check.check_step`:
the controller, the motor lag, the inner loops on ``full``; ``|λ| dt ≤ 2.5``).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from typing import Any, Callable, Mapping, Sequence

import casadi as ca
import numpy as np

from nniquad.config import XI0_M
from nniquad.errors import GainError, SimulationError
from nniquad.laws.base import GainBlock
from nniquad.laws.nni import PAPER_GAINS
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle
from nniquad.resources import usable_cpu_count
from nniquad.sim.models import chunk_function, output_function
from nniquad.sim.options import MODELS, SimOptions, check_model
from nniquad.sim.params import (EXO_FIELDS, OUTPUT_NAMES, SimParams, check_controller, delay_state_names, n_params,
                                state_names, to_gains)
from nniquad.sim.results import SimulationResult, Trajectory
from nniquad.sim.step_check import check_step

__all__ = ["simulate", "run_batch", "exogenous_inputs", "initial_state", "paper_figure_runs",
           "PAPER_FIGURE_HORIZON_S"]


#: Threads of one batched call; ``None``: every usable CPU (:func:`set_batch_threads`).
_BATCH_THREADS: int | None = None


def set_batch_threads(n: int | None) -> None:
    """Cap the threads of a batched simulation at ``n`` (``None``: every usable CPU of this process).

    A process pool of ``W`` workers on ``C`` CPUs gives each worker ``C // W``
    threads (:mod:`nniquad.study.executors`), so that the workers' batches do not
    take turns on the same cores.

    Parameters
    ----------
    n
        Largest number of threads, or ``None``.
    """
    global _BATCH_THREADS
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
        raise SimulationError(f"batch threads must be a positive integer or None, got {n!r}")
    _BATCH_THREADS = n


def batch_threads(runs: int) -> int:
    """Threads a batch of ``runs`` runs uses: at most one per run and per usable CPU (or the cap).

    Parameters
    ----------
    runs
        Number of runs in the batch.
    """

    cap = usable_cpu_count() if _BATCH_THREADS is None else _BATCH_THREADS
    return max(1, min(int(runs), cap))


@lru_cache(maxsize=64)
def _segment_function(model: str, K: int, M: int, B: int, shared_exo: bool, controller: str = "nni",
                      delay_samples: int = 0) -> ca.Function:
    """``M`` output samples of ``B`` runs, evaluated in turn on the calling thread:
    ``seg(x0[nx x B], E[n_exo x K M (B)], p[np x B]) -> (X, Y)``.

    The runs of a batch are spread over threads by :func:`run_batch`, one such function
    per thread, not by CasADi's ``"thread"`` map: CasADi's Python binding releases the GIL
    during the call, so the threads run at once.  Why the ``"thread"`` map is slower was not
    isolated (docs/notes/speed.md); measured on 2 cores, 40 full-model runs of 20 s: 0.38 s this way against 0.43-0.47 s
    with the ``"thread"`` map, and 0.76 s one by one (``benchmarks/bench_simulate.py``).
    """
    chunk = chunk_function(model, K, controller, delay_samples)
    acc = chunk.mapaccum("samples", M)
    nx = chunk.size1_in(0)
    x = ca.MX.sym("x", nx)
    E = ca.MX.sym("E", len(EXO_FIELDS), K * M)
    p = ca.MX.sym("p", n_params(controller))
    # p is the same for every sample of a run: repeat it explicitly (mapaccum maps every non-accumulated input)
    Xs, Ys = acc(x, E, ca.repmat(p, 1, M))
    sfx = f"_{controller}" + (f"_delay{delay_samples}" if delay_samples else "")
    seg = ca.Function(f"seg_{model}{sfx}_{K}_{M}", [x, E, p], [Xs, Ys], ["x0", "E", "p"], ["X", "Y"])
    if B == 1:
        return seg
    reduce_in = [1] if shared_exo else []
    return seg.map(f"batch_{model}{sfx}_{K}_{M}_{B}", "serial", B, reduce_in, [])


def _thread_slices(B: int, threads: int) -> list[slice]:
    """Contiguous, nearly equal slices of ``range(B)``, one per thread (the first ones one run longer)."""
    n = max(1, min(B, threads))
    base, extra = divmod(B, n)
    out, lo = [], 0
    for i in range(n):
        hi = lo + base + (1 if i < extra else 0)
        out.append(slice(lo, hi))
        lo = hi
    return out


# =============================================================================== exogenous inputs and state


def exogenous_inputs(options: SimOptions, n_steps: int | None = None, seed: int | None = None) -> np.ndarray:
    """Per-step exogenous inputs ``(n_steps, n_exo)`` (:data:`EXO_FIELDS`) for the options.

    Reference (with ``options.reference``): its position and velocity and, with
    ``options.feedforward``, its acceleration (``feedforward_lead_s`` ahead), read with the
    measurement (:func:`_reference_columns`).

    Noise: ``σ · N(0, 1)`` drawn at each sensor sample instant (the first step at
    or after ``k / rate``), constant until the next.  Gust: first-order
    Gauss-Markov force per axis, ``g_{k+1} = a g_k + sqrt(1 - a²) σ_g w_k`` with
    ``a = exp(-dt/τ_g)``, started from its stationary distribution.  Noise and
    gust use independent streams of ``numpy.random.default_rng([seed, i])``.
    """
    o = options
    n = o.n_samples * o.steps_per_sample if n_steps is None else int(n_steps)
    seed = o.seed if seed is None else seed
    E = np.zeros((n, len(EXO_FIELDS)))
    t = np.arange(n) * o.dt_s
    idx = np.floor(t * o.noise_rate_hz + 1e-9).astype(np.int64)
    flag = np.full(n, 2.0)  # 2: a later sample (the discrete controller advances, then latches)
    flag[1:][idx[1:] == idx[:-1]] = 0.0
    if n:
        flag[0] = 1.0  # the first sample of the run only latches (EXO_FIELDS)
    E[:, 2] = flag
    if o.noise_sigma_m > 0:
        rng = np.random.default_rng([seed, 0])
        draws = o.noise_sigma_m * rng.standard_normal((int(idx[-1]) + 1 if n else 0, 2))
        E[:, 0:2] = draws[idx]
    if o.gust_N > 0:
        from scipy.signal import lfilter

        rng = np.random.default_rng([seed, 1])
        a = math.exp(-o.dt_s / o.gust_tau_s)
        w = rng.standard_normal((n, 2))
        c = o.gust_N * math.sqrt(1 - a * a)
        g0 = o.gust_N * w[0]  # stationary start
        E[0, 3:5] = g0
        for axis in range(2):  # g_k = a g_{k-1} + c w_k
            E[1:, 3 + axis] = lfilter([c], [1.0, -a], w[1:, axis], zi=[a * g0[axis]])[0]
    if o.reference is not None and n:
        _reference_columns(E, o, t, idx)
    return E


def _reference_columns(E: np.ndarray, o: SimOptions, t: np.ndarray, idx: np.ndarray) -> None:
    """Fill the reference's columns of ``E`` (:data:`EXO_FIELDS`): the controller reads the reference when it
    reads the measurement.  Sampled: at the sample instant, held until the next sample (what a discrete
    controller is given with ``ξ_k``).  Continuous: at the middle of each step, since every input is held over
    a step (second order in ``dt``, no half-step lag)."""
    if o.sampled:
        instants = idx / o.noise_rate_hz
        first = np.r_[0, np.flatnonzero(np.diff(idx)) + 1]  # the step of each sample instant
        which = np.searchsorted(first, np.arange(t.size), side="right") - 1
        read = instants[first]
    else:
        which, read = slice(None), t + 0.5 * o.dt_s
    pos, vel, _ = o.reference.sample(read)
    acc = o.reference.sample(read + o.feedforward_lead_s)[2]
    pos, vel, acc = pos[which], vel[which], acc[which]
    cols = [EXO_FIELDS.index(n) for n in ("ref_x", "ref_y", "ref_vx", "ref_vy", "ff_x", "ff_y")]
    E[:, cols[0:2]], E[:, cols[2:4]] = pos, vel
    if o.feedforward:
        E[:, cols[4:6]] = acc


def initial_state(model: str, params: SimParams, xi0: Sequence[float] = XI0_M,
                  zc0: Sequence[float] = (0.0, 0.0), v0: Sequence[float] = (0.0, 0.0),
                  ref0: Sequence[float] = (0.0, 0.0), delay_samples: int = 0) -> np.ndarray:
    """Initial state: at ``xi0`` with the horizontal velocity ``v0`` (default at rest), level, ψ = 0, z = 0;
    motors at the nominal hover speed.

    Controller states: the law's start for the measured error ``e_0 = xi0 - ref0`` (``ref0`` the reference's
    position at ``t = 0``; :meth:`nniquad.laws.base.ControlLaw.sim_start_state`: the NNI law at zero, the
    ``sni2`` law at rest at its DC value ``z = C(0) e_0``, the filtered PD's filter at ``d = e_0``), plus ``zc0``
    on each axis's first state.  That is the state consistent with a start from motion
    (:mod:`nniquad.laws.base`, "Reference and feedforward").  The measurement delay line of ``delay_samples``
    samples per axis holds ``e_0`` too: the vehicle sat at ``xi0`` before take-over.
    """
    check_model(model)
    controller = params.controller
    names = state_names(model, controller, delay_samples)
    x0 = np.zeros(len(names))
    ix = {n: i for i, n in enumerate(names)}
    x0[ix["x"]], x0[ix["y"]] = xi0
    x0[ix["x_dot"]], x0[ix["y_dot"]] = v0
    e0 = np.asarray(xi0, float) - np.asarray(ref0, float)
    law = params.gains.law
    sim_names = law.sim_state_names
    if sim_names:
        start = law.sim_start_state(params.gains, float(params.nominal.m), e0)
        for name, v in zip(sim_names, start):
            x0[ix[name]] = v
        x0[ix[sim_names[0]]] += zc0[0]
        x0[ix[sim_names[1]]] += zc0[1]
    x0[ix["held_x"]], x0[ix["held_y"]] = e0
    for name in delay_state_names(delay_samples):
        x0[ix[name]] = e0[0 if name.endswith("_x") else 1]
    if model == "full":
        nom = params.nominal
        w_hover = math.sqrt(nom.m * nom.g / (4 * nom.b))
        for i in range(1, 5):
            x0[ix[f"w{i}"]] = w_hover
    return x0


def _check_step(params: Sequence[SimParams], model: str) -> None:
    """Refuse what the runner cannot integrate: a step too large for a pole (:func:`check_step`), or a
    discrete controller that is not the NNI law or not fed the sampled measurement."""
    for p in params:
        if p.run.discrete > 0.5 and p.run.sample_hold < 0.5:
            raise SimulationError("the discrete controller needs the sampled measurement (run.sample_hold = 1)")
    check_step(params, model)


# =============================================================================== running


def run_batch(
    model: str,
    params: np.ndarray,
    x0: np.ndarray,
    exo: np.ndarray,
    *,
    steps_per_sample: int,
    n_samples: int,
    progress: Callable[[float], None] | None = None,
    n_segments: int | None = None,
    controller: str = "nni",
    delay_samples: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Low-level batched run of parameter vectors; the building block of :func:`simulate`.

    Parameters
    ----------
    model
        One of :data:`MODELS`.
    params
        ``(B, n_params(controller))`` parameter vectors (:meth:`SimParams.vector`);
        the RK4 step is checked by :func:`simulate`, not here.
    x0
        ``(B, nx)`` initial states (:func:`initial_state`).
    exo
        ``(n_steps, n_exo)`` shared by all runs, or ``(B, n_steps, n_exo)`` per run (``n_exo`` the
        length of :data:`EXO_FIELDS`), with
        ``n_steps >= steps_per_sample * n_samples``.
    steps_per_sample, n_samples
        ``K`` RK4 steps per output sample, number of output samples.
    progress
        Called with the completed fraction after every segment.
    n_segments
        Number of calls into CasADi (more gives finer progress); default about 20.
    controller
        One of :data:`CONTROLLERS` (the layout of ``params``).
    delay_samples
        Length of the measurement delay line (:attr:`SimOptions.delay_samples`; the layout of ``x0``).

    Returns
    -------
    X : ndarray (B, n_samples + 1, nx)
        States at the output samples, the initial state first.
    Y : ndarray (B, n_samples + 1, ny)
        Outputs (:data:`OUTPUT_NAMES`) at the samples (the first from ``x0``).
    """
    check_model(model)
    check_controller(controller)
    n_p = n_params(controller)
    P = np.atleast_2d(np.asarray(params, float))
    X0 = np.atleast_2d(np.asarray(x0, float))
    B = P.shape[0]
    nx, ny = len(state_names(model, controller, delay_samples)), len(OUTPUT_NAMES[model])
    if P.shape[1] != n_p:
        raise ValueError(f"params must have {n_p} columns, got {P.shape[1]}")
    if X0.shape != (B, nx):
        raise ValueError(f"x0 must have shape ({B}, {nx}), got {X0.shape}")
    if not np.all(np.isfinite(P)):
        raise SimulationError("parameter vector has a non-finite entry")
    K, N = int(steps_per_sample), int(n_samples)
    if K < 1 or N < 1:
        raise SimulationError("steps_per_sample and n_samples must be at least 1")
    E = np.asarray(exo, float)
    shared = E.ndim == 2
    ne = len(EXO_FIELDS)
    if (shared and (E.shape[1] != ne)) or (not shared and (E.ndim != 3 or E.shape[0] != B or E.shape[2] != ne)):
        raise ValueError(f"exo must have shape (n_steps, {ne}) or ({B}, n_steps, {ne}), got {E.shape}")
    if E.shape[-2] < K * N:
        raise ValueError(f"exo has {E.shape[-2]} steps, the run needs {K * N}")
    n_seg = max(1, min(N, n_segments if n_segments is not None else 20))
    M = int(math.ceil(N / n_seg))
    n_seg = int(math.ceil(N / M))
    slices = _thread_slices(B, batch_threads(B))
    out_fn = output_function(model, controller)
    Xall = np.empty((B, N + 1, nx))
    Yall = np.empty((B, N + 1, ny))
    Xall[:, 0] = X0
    e0 = E[0] if shared else E[:, 0]
    nb = len(state_names(model, controller))
    for b in range(B):
        Yall[b, 0] = np.asarray(out_fn(X0[b, :nb], e0 if shared else e0[b], P[b])).ravel()
    # Zero-copy calls (FunctionBuffer): CasADi is column-major, so a (rows, cols) CasADi
    # matrix is a C-contiguous numpy array of shape (cols, rows): x0 (nx x B) <-> (B, nx),
    # E (n_exo x B M K) <-> (B, M K, n_exo), outputs (nx x B M) <-> (B, M, nx).  A slice of runs
    # of these arrays is contiguous too: each thread's buffer points into the shared arrays.
    xc = np.array(X0, order="C")  # a copy: it is overwritten in place after every segment
    Pc = np.ascontiguousarray(P)
    Xout = np.empty((B, M, nx))
    Yout = np.empty((B, M, ny))
    Eseg = np.zeros((M * K, ne)) if shared else np.zeros((B, M * K, ne))
    calls = []
    for part in slices:
        buf, trigger = _segment_function(model, K, M, part.stop - part.start, shared, controller,
                                          delay_samples).buffer()
        buf.set_arg(0, memoryview(xc[part]))
        buf.set_arg(1, memoryview(Eseg if shared else Eseg[part]))
        buf.set_arg(2, memoryview(Pc[part]))
        buf.set_res(0, memoryview(Xout[part]))
        buf.set_res(1, memoryview(Yout[part]))
        calls.append((buf, trigger))
    pool = ThreadPoolExecutor(len(calls) - 1, thread_name_prefix="nniquad-batch") if len(calls) > 1 else None
    try:
        done = 0
        for _ in range(n_seg):
            m_here = min(M, N - done)
            lo, hi = done * K, (done + M) * K
            piece = E[lo:min(hi, E.shape[0])] if shared else E[:, lo:min(hi, E.shape[1])]
            Eseg[..., : piece.shape[-2], :] = piece
            Eseg[..., piece.shape[-2] :, :] = 0.0  # only a last, short segment has a tail past the run
            others = [pool.submit(trigger) for _, trigger in calls[1:]] if pool is not None else []
            calls[0][1]()  # the calling thread runs the first slice
            for future in others:
                future.result()
            failed = [buf.ret() for buf, _ in calls if buf.ret() != 0]
            if failed:
                raise SimulationError(f"CasADi evaluation of a {model} segment failed (status {failed[0]})")
            Xall[:, done + 1 : done + 1 + m_here] = Xout[:, :m_here]
            Yall[:, done + 1 : done + 1 + m_here] = Yout[:, :m_here]
            xc[...] = Xout[:, M - 1]  # in place: the buffers keep pointing at xc
            done += m_here
            if progress is not None:
                progress(done / N)
    finally:
        if pool is not None:
            pool.shutdown(wait=True)
    return Xall, Yall


# =============================================================================== the entry point

GainsLike = GainBlock | Mapping[str, Any] | Sequence[float]


def _as_list(value: Any, kind: type, what: str) -> list:
    if isinstance(value, kind):
        return [value]
    try:
        items = list(value)
    except TypeError:
        raise SimulationError(f"{what} must be a {kind.__name__} or a sequence of them, got {value!r}") from None
    bad = [x for x in items if not isinstance(x, kind)]
    if bad:
        raise SimulationError(f"{what} must be a {kind.__name__} or a sequence of them, got {bad[0]!r}")
    return items


def _gain_list(gains: Any) -> list[GainBlock]:
    """One gain set (a block, a mapping, a tuple of numbers) or a sequence of gain sets."""
    if gains is None:
        return [PAPER_GAINS]
    if isinstance(gains, (GainBlock, Mapping, str, bytes)):
        return [to_gains(gains)]
    try:
        items = list(gains)
    except TypeError:
        raise GainError(f"cannot read a gain set from {gains!r}") from None
    if items and all(isinstance(x, (int, float, np.integer, np.floating)) for x in items):
        return [to_gains(items)]  # one tuple (kp, Gamma, delta[, kpy])
    return [to_gains(g) for g in items]


def _broadcast(name: str, items: list, n: int) -> list:
    if len(items) == n:
        return items
    if len(items) == 1:
        return items * n
    raise SimulationError(f"{len(items)} {name} given for {n} runs (give one, or one per run)")


def _exo_key(o: SimOptions) -> tuple:
    return (o.seed, o.noise_sigma_m, o.noise_rate_hz, o.gust_N, o.gust_tau_s, o.dt_s, o.n_samples,
            o.steps_per_sample, o.reference, o.feedforward, o.feedforward_lead_s, o.sampled)


def _start_of(o: SimOptions) -> tuple[float, float]:
    """The reference's position at ``t = 0`` (the origin without one)."""
    if o.reference is None:
        return (0.0, 0.0)
    x, y = o.reference.position(0.0)[0]
    return (float(x), float(y))


def simulate(
    vehicle: Vehicle | None = None,
    gains: GainsLike | Sequence[GainsLike] | None = None,
    options: SimOptions | Sequence[SimOptions] | None = None,
    *,
    params: SimParams | Sequence[SimParams] | None = None,
    progress: Callable[[float], None] | None = None,
) -> SimulationResult:
    """Simulate one or many closed-loop runs in one batched call.

    Parameters
    ----------
    vehicle
        Controller model and plant (default the paper's).  With ``params`` it
        only labels the result (default ``None`` there).
    gains
        One gain set or a sequence of them (one run each): a
        gain block of a registered law (:mod:`nniquad.laws`: :class:`~nniquad.laws.nni.Gains`,
        :class:`~nniquad.laws.sni2.SNI2Gains`, ...) -- the block's type is the controller law --
        or a mapping / ``(kp, Gamma, delta[, kpy])`` tuple of NNI gains.
        Default the paper's gains.  All runs must use one law.
    options
        A :class:`SimOptions` for every run, or one per run (they must share
        model, horizon, step and output period); default ``SimOptions()``.
    params
        Ready parameter sets, one per run (e.g. perturbed plants), instead of
        the ones built from ``vehicle``, ``gains`` and ``options``
        (:meth:`SimParams.from_options`); ``gains`` must then be ``None``.  The
        options still give the initial state, the noise and gust, and timing.
    progress
        Called with the completed fraction after every segment.

    Returns
    -------
    SimulationResult
        ``B`` runs, ``B`` the longest of the gain, option and parameter lists
        (a list of length one is used for every run); ``result[i]`` is run ``i``.
        Runs whose options give the same noise and gust share one realisation
        (common random numbers, so gain sets are compared on equal terms).

    Raises
    ------
    GainError
        Invalid gains, gain sets of different laws, or both ``gains`` and ``params``.
    SimulationError
        Invalid options, option sets of different timing, a too large step.
    """
    olist = [SimOptions()] if options is None else _as_list(options, SimOptions, "options")
    if params is not None:
        if gains is not None:
            raise GainError("give either gains or params, not both (params hold the gains)")
        plist: list[SimParams] | None = _as_list(params, SimParams, "params")
        glist = [p.gains for p in plist]
    else:
        plist = None
        vehicle = PAPER_VEHICLE if vehicle is None else vehicle
        if not isinstance(vehicle, Vehicle):
            raise SimulationError(f"vehicle must be a Vehicle, got {type(vehicle).__name__}")
        glist = _gain_list(gains)
    if not glist or not olist:
        raise GainError("no gain set given") if not glist else SimulationError("no options given")
    B = max(len(glist), len(olist))
    glist, olist = _broadcast("gain sets", glist, B), _broadcast("option sets", olist, B)
    laws = sorted({g.controller for g in glist})
    if len(laws) > 1:
        raise GainError(f"one simulate call runs one controller law, got {' and '.join(laws)}")
    controller = laws[0]
    first = olist[0]
    timing = (first.model, first.n_samples, first.steps_per_sample, first.dt_s, first.delay_samples)
    for o in olist:
        if (o.model, o.n_samples, o.steps_per_sample, o.dt_s, o.delay_samples) != timing:
            raise SimulationError("all option sets of one simulate call must share model, horizon, dt, output dt "
                                  "and measurement delay")
    if plist is None:
        plist = [SimParams.from_options(vehicle, g, o) for g, o in zip(glist, olist)]
    _check_step(plist, first.model)
    for p, o in zip(plist, olist):
        # the discrete controller's period is a parameter; it must be the period the sample flags follow
        if p.run.discrete > 0.5 and abs(p.run.sample_period * o.noise_rate_hz - 1.0) > 1e-9:
            raise SimulationError(f"discrete controller period {p.run.sample_period:g} s differs from the sample "
                                  f"period 1/{o.noise_rate_hz:g} Hz of the options")
    model = first.model
    P = np.stack([p.vector() for p in plist])
    delay = first.delay_samples
    X0 = np.stack([initial_state(model, p, o.xi0, o.zc0, o.v0, _start_of(o), delay) for p, o in zip(plist, olist)])
    keys = {_exo_key(o) for o in olist}
    if len(keys) == 1:
        E = exogenous_inputs(first)
    else:
        cache: dict[tuple, np.ndarray] = {}
        E = np.stack([cache.setdefault(_exo_key(o), exogenous_inputs(o)) for o in olist])
    X, Y = run_batch(model, P, X0, E, steps_per_sample=first.steps_per_sample, n_samples=first.n_samples,
                     progress=progress, controller=controller, delay_samples=delay)
    t = np.arange(first.n_samples + 1) * first.output_dt_s
    return SimulationResult(model, t, X, Y, state_names(model, controller, delay), OUTPUT_NAMES[model], tuple(glist), tuple(olist),
                            tuple(plist), vehicle)


#: Horizon of the paper's figure [s]: the paper-gain linear loop has a dominant pair with
#: damping ~0.013 (decay 0.017 1/s) and settles (2 %) only after ~224 s; 300 s shows it
#: staying in the band, and the full vehicle's growing oscillation.
PAPER_FIGURE_HORIZON_S = 300.0


def paper_figure_runs(
    vehicle: Vehicle | None = None,
    gains: GainsLike = PAPER_GAINS,
    horizon_s: float = PAPER_FIGURE_HORIZON_S,
    *,
    options: SimOptions | None = None,
    progress: Callable[[float], None] | None = None,
) -> dict[str, Trajectory]:
    """The runs of the figure the paper meant to show: one trajectory per model, same gains.

    ``options`` (model and horizon ignored) sets anything else; the default is
    the paper's initial state without noise or wind.

    Parameters
    ----------
    vehicle
        The vehicle; default the paper's.
    gains
        The gains (default the paper's).
    horizon_s
        Simulated time of every run [s].
    options
        Anything else (model and horizon are replaced).
    progress
        Called with the completed fraction.
    """
    base = SimOptions() if options is None else options
    runs: dict[str, Trajectory] = {}
    for i, model in enumerate(MODELS):
        sub = None
        if progress is not None:
            sub = lambda f, i=i: progress((i + f) / len(MODELS))  # noqa: E731
        runs[model] = simulate(vehicle, gains, base.with_(model=model, horizon_s=horizon_s), progress=sub)[0]
    return runs
