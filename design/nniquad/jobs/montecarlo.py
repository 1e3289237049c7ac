"""The job ``montecarlo``: a robustness study of a certificate, as one result object."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

from nniquad.certificates import load_certificate
from nniquad.errors import MonteCarloError, StudyFailedError
from nniquad.scenarios.draws import (
    DEFAULT_RANGES,
    ScenarioRanges,
    StudySetup,
    draw_scenarios,
    within_certificate_ranges,
)
from nniquad.scenarios.setup import check_study_step
from nniquad.study.certificate_setup import study_setup
from nniquad.study.executors import StopRequest, StudyRun, run_study
from nniquad.study.statistics import Summary, summarize

__all__ = ["MonteCarloResult", "montecarlo"]


@dataclass(frozen=True)
class MonteCarloResult:
    """A finished (or interrupted) Monte Carlo study (see :func:`montecarlo`).

    Attributes
    ----------
    setup
        What every scenario shares (gains, vehicle, horizon, settling band, ...).
    ranges
        The perturbation ranges the scenarios were drawn from.
    seed
        Seed of the study: scenario ``i`` is stream ``i`` of this seed.
    run
        The per-scenario results, how they were computed, and whether the study was interrupted.
    summary
        Success rate, quantiles and worst cases; ``None`` when no scenario finished.
    """

    setup: StudySetup
    ranges: ScenarioRanges
    seed: int
    run: StudyRun
    summary: Summary | None

    @property
    def partial(self) -> bool:
        """True when the study stopped early (only finished scenarios are in :attr:`run`)."""
        return self.run.partial

    @property
    def success_rate(self) -> float:
        """Fraction of the finished scenarios that settled to the setpoint and never diverged (``nan`` if none finished)."""
        return float("nan") if self.summary is None else self.summary.success_rate

    def __repr__(self) -> str:
        if self.summary is None:
            return f"MonteCarloResult(seed={self.seed}, no scenario finished)"
        s = self.summary
        lo, hi = s.success_ci
        return (f"MonteCarloResult(seed={self.seed}, {s.n_success}/{s.n} succeeded = {100 * s.success_rate:.1f} % "
                f"[{100 * lo:.1f}, {100 * hi:.1f}] (Wilson 95 %){', PARTIAL' if self.partial else ''})")

    def table(self, rerun_hint: str | None = None) -> str:
        """The summary as a text table with units and 95 % intervals.

        Parameters
        ----------
        rerun_hint
            A command line that reruns one scenario, shown under the worst cases.
        """
        return "no scenario finished" if self.summary is None else self.summary.table(rerun_hint=rerun_hint)

    def to_json(self) -> dict[str, Any]:
        """``partial, stopped, completed, requested, study, run, summary, results`` (units in the key names).

        ``stopped`` is ``None`` for a complete study, else ``{"kind", "reason"}``: ``kind`` is
        ``"interrupted"`` (Ctrl-C), ``"terminated"`` (SIGTERM, caught by the command line) or the fault
        (``"worker"``, ``"scheduler"``, ``"stalled"``, ``"error"``).
        """
        r = self.run
        return {
            "partial": r.partial,
            "stopped": None if r.stopped is None else {"kind": r.stopped, "reason": r.reason},
            "completed": len(r.results),
            "requested": r.n_requested,
            "study": {"seed": self.seed, "samples": r.n_requested, "setup": self.setup.to_json(),
                      "ranges": self.ranges.to_json()},
            "run": {"executor": r.executor, "workers": r.workers, "batch_size": r.batch_size,
                    "elapsed_s": r.elapsed_s, "scenarios_per_s": r.scenarios_per_s},
            "summary": None if self.summary is None else self.summary.to_json(),
            "results": [x.to_json() for x in r.results],
        }


def montecarlo(certificate: Any, samples: int = 1000, seed: int = 0, *, ranges: ScenarioRanges = DEFAULT_RANGES,
               horizon_s: float | None = None, workers: int | None = None, scheduler: str | None = None,
               client: Any = None, batch_size: int | None = None, n_worst: int = 10,
               progress: Callable[[int, int], None] | None = None, stall_timeout_s: float | None = None,
               stop: StopRequest | None = None, notify: Callable[[str], None] | None = None,
               within_certificate: bool = False) -> MonteCarloResult:
    """Simulate perturbed scenarios of a certificate's gain set on the full vehicle and summarise them.

    Parameters
    ----------
    certificate
        A :class:`nniquad.certificates.Certificate`, a loaded certificate
        mapping, a certificate file path, or a :class:`StudySetup`.
    samples
        Number of scenarios.
    seed
        Seed of the study; scenario ``i`` of seed ``S`` is the same whatever
        ``samples``, the batch size or the number of workers.
    ranges
        Perturbation ranges (default :data:`DEFAULT_RANGES`).
    horizon_s
        Simulated time per scenario [s] (default 20 s).
    workers
        Local worker processes (default: all cores; 1 runs in this process).
    scheduler
        Address of a running Dask scheduler (``tcp://host:port``) instead of the local pool.
    client
        An existing ``dask.distributed.Client`` instead of ``scheduler``.
    batch_size
        Scenarios per unit of work (default: about four batches per worker, at most 50).
    n_worst
        Worst cases kept in the summary.
    progress
        Called as ``progress(done, total)`` after each finished batch.
    stall_timeout_s, stop, notify
        See :func:`nniquad.study.run_study` (a pool or cluster on which no
        batch finished for this long has stalled; a stop request, set by
        Ctrl-C by default; one-line notes while waiting).
    within_certificate
        Draw only inside what the certificate's ``cascade`` section certifies
        (:func:`nniquad.study.within_certificate_ranges`: its box, region and
        rate, no noise, no wind); ``ranges`` must then be left at the default.
        Every scenario of such a study is expected to converge.

    Returns
    -------
    MonteCarloResult
        ``partial`` when interrupted (Ctrl-C): the finished batches are kept.

    Raises
    ------
    MonteCarloError
        Bad options, a pole of the fastest scenario too fast for the RK4 step
        (:func:`check_study_step`), an unreachable scheduler.
    StudyFailedError
        A fault while the study ran (a worker or the scheduler died, a stall,
        an unexpected error); its ``result`` is the :class:`MonteCarloResult`
        of the finished scenarios, ``partial``.
    CertificateError
        An unreadable or tampered certificate.
    """
    if isinstance(certificate, (str, Path)):

        certificate = load_certificate(certificate)
    elif not isinstance(certificate, (Mapping, StudySetup)):
        to_json = getattr(certificate, "to_json", None)
        certificate = to_json() if callable(to_json) else certificate
    if within_certificate:
        if isinstance(certificate, StudySetup) or not isinstance(certificate, Mapping):
            raise MonteCarloError("within_certificate needs the certificate itself (a mapping), not a StudySetup")
        if ranges is not DEFAULT_RANGES:
            raise MonteCarloError("within_certificate takes its ranges from the certificate: give no ranges")
        ranges, region, _ = within_certificate_ranges(certificate)
        setup = study_setup(certificate, ranges, horizon_s=horizon_s, region_m=region)
    else:
        setup = study_setup(certificate, ranges, horizon_s=horizon_s)
    check_study_step(setup, ranges)
    scenarios = draw_scenarios(samples, seed, ranges, setup)
    try:
        run = run_study(scenarios, workers=workers, scheduler=scheduler, client=client, batch_size=batch_size,
                        progress=progress, stall_timeout_s=stall_timeout_s, stop=stop, notify=notify)
    except StudyFailedError as exc:  # what finished goes with the error
        try:
            summary = summarize(exc.run.results, n_worst=n_worst, partial=True) if exc.run.results else None
        except Exception:  # noqa: BLE001 -- the fault is the news; the results are kept without a summary
            summary = None
        exc.result = MonteCarloResult(setup, ranges, int(seed), exc.run, summary)
        raise
    summary = summarize(run.results, n_worst=n_worst, partial=run.partial) if run.results else None
    return MonteCarloResult(setup, ranges, int(seed), run, summary)
