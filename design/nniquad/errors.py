"""Domain exceptions.

Every error a user can cause (bad vehicle file, non-finite gain, tampered
certificate, ...) is raised as a subclass of :class:`NniquadError`; the CLI turns
those into a one-line message and a non-zero exit status, never a traceback.

Exit status (:mod:`nniquad.cli.main`, the same for every command): each class
carries its ``exit_code``.  :data:`EXIT_USER_ERROR` (2) is the default; a check
that ran and failed (a certificate that does not verify, a digest mismatch) is
:class:`CheckFailedError` with :data:`EXIT_CHECK_FAILED` (1).
"""

from __future__ import annotations

__all__ = [
    "NniquadError",
    "VehicleError",
    "GainError",
    "SolverError",
    "CertificateError",
    "SimulationError",
    "MonteCarloError",
    "CascadeError",
    "ExportError",
    "InputError",
    "OutputError",
    "ResourceError",
    "CheckFailedError",
    "CertificateCheckError",
    "EXIT_OK",
    "EXIT_CHECK_FAILED",
    "EXIT_USER_ERROR",
    "EXIT_INTERNAL_ERROR",
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
    "Terminated",
    "StudyFailedError",
    "EXIT_STUDY_FAILED",
]

#: The command did what was asked (and every check it ran passed).
EXIT_OK = 0
#: The command ran, and a check it ran failed (verify, prove --strict, a certificate that does not verify).
EXIT_CHECK_FAILED = 1
#: Bad input: an option, a file, an output path, a request too large for this machine.  Nothing was written.
EXIT_USER_ERROR = 2
#: An unexpected exception: a bug in nniquad (the only case with a traceback).
EXIT_INTERNAL_ERROR = 3
#: Interrupted by Ctrl-C / SIGINT (128 + 2, the shell convention).
EXIT_INTERRUPTED = 130
#: Terminated by SIGTERM (128 + 15, the shell convention); handled like SIGINT.
EXIT_TERMINATED = 143

#: Exit status of a Monte Carlo study stopped by a fault of where it ran (a worker or the scheduler
#: died, the cluster stopped making progress); its finished scenarios are saved.
EXIT_STUDY_FAILED = 4


class NniquadError(ValueError):
    """Base class of all user-facing errors of the project."""

    #: Exit status of the command line for this error.
    exit_code: int = EXIT_USER_ERROR


class VehicleError(NniquadError):
    """A vehicle parameter set or file is malformed or physically impossible."""


class GainError(NniquadError):
    """A gain set is non-finite, non-positive or outside a required bound."""


class SolverError(NniquadError):
    """A convex solver failed, or returned data that does not pass the re-check."""


class CertificateError(NniquadError):
    """A certificate is malformed, tampered with, or does not verify."""


class SimulationError(NniquadError):
    """A simulation option is invalid (negative horizon, zero rate, ...)."""


class MonteCarloError(NniquadError):
    """A Monte Carlo option is invalid, or the cluster cannot be reached or failed."""


class CascadeError(NniquadError):
    """The linearised cascade cannot be built or analysed as asked (no hover equilibrium, an inexact
    plant/controller split, an unknown break point or controller variant, a non-positive sample rate)."""


class ExportError(NniquadError):
    """A controller cannot be exported as asked (bad rate or format, unwritable folder, sampled loop
    unstable at the rate)."""


class InputError(NniquadError):
    """An input file is not a regular file of sane size, not UTF-8 text, or not valid JSON/TOML."""


class OutputError(NniquadError):
    """An output path cannot be written (a folder, a file used as a folder, no permission, ...)."""


class ResourceError(NniquadError):
    """A request needs more memory (or time) than this machine can give it."""


class CheckFailedError(NniquadError):
    """A check ran and failed (exit status 1, not a user error)."""

    exit_code = EXIT_CHECK_FAILED


class CertificateCheckError(CertificateError, CheckFailedError):
    """A certificate that reads as one but does not verify (digest mismatch, failed own verification)."""

    exit_code = EXIT_CHECK_FAILED


class StudyFailedError(MonteCarloError):
    """A running Monte Carlo study stopped on a fault; it carries what had finished.

    Attributes
    ----------
    kind
        ``"worker"`` (a worker died or raised), ``"scheduler"`` (the Dask scheduler was lost),
        ``"stalled"`` (no batch finished within the stall timeout) or ``"error"`` (an unexpected
        exception, a bug: it is the ``__cause__``).
    reason
        The one-line message.
    run
        The :class:`nniquad.study.StudyRun` of the finished scenarios (``partial``), set by the executor.
    result
        The :class:`nniquad.study.MonteCarloResult` of them, set by :func:`nniquad.montecarlo`.
    """

    exit_code = EXIT_STUDY_FAILED

    def __init__(self, reason: str, kind: str = "error") -> None:
        super().__init__(reason)
        self.reason = reason
        self.kind = kind
        self.run = None
        self.result = None


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where Ctrl-C raises ``KeyboardInterrupt`` (:func:`nniquad.cli.main.main` installs it).

    A subclass of ``KeyboardInterrupt``, so that everything that cleans up
    after Ctrl-C -- temporary files, a report's build folder, a Monte Carlo
    study's pending batches -- does the same for SIGTERM; the command then
    exits with :data:`EXIT_TERMINATED`.
    """
