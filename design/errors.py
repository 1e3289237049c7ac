"""Domain exceptions.

Every error a user can cause (bad vehicle file, non-finite gain, tampered
certificate, ...) is raised as a subclass of :class:`NniquadError`; the CLI turns
those into a one-line message and a non-zero exit status, never a traceback.
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
]


class NniquadError(ValueError):
    """Base class of all user-facing errors of the project."""


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
