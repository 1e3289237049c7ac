"""A certificate's reference run: the one object the certificate is built, verified and re-flown with.

:class:`ReferenceRun` holds everything a reference run uses -- the vehicle, the
gains (so the law), and the complete :class:`nniquad.sim.SimOptions`: inner loops,
control rate and sampling, motor lag, start, horizon, tilt limit, output period.
:func:`nniquad.certificates.build.performance_runs` builds one per model from
:func:`nniquad.certificates.certificate.reference_run_options` and records its
options as ``performance.<model>.settings``; :func:`reference_run_of` reads that
record back (:meth:`nniquad.certificates.certificate.Certificate.run_settings`),
and :func:`nniquad.certificates.recheck_runs.performance_check`, ``simulate
--certificate`` and :func:`nniquad.jobs.certificate_run.simulate_certificate` fly what it returns.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any, Callable, Mapping

from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CertificateError, NniquadError
from nniquad.laws.base import GainBlock
from nniquad.model.vehicle import Vehicle
from nniquad.sim import SimOptions, SimulationResult, simulate
from nniquad.sim.verdicts import Metrics

__all__ = ["RUN_METRICS", "LATER_RUN_METRICS", "METRIC_TOLERANCES", "ReferenceRun", "reference_run_of", "run_metrics"]

#: The numbers a certificate states of each reference run (``performance.<model>``), besides its ``settings``.
#: ``steady_offset_m`` (the mean distance from the setpoint over the run's last second) only since issue 44: an
#: older certificate does not state it (:data:`nniquad.certificates.certificate.LATER_TOLERANCES`).
RUN_METRICS = ("settling_s", "overshoot_pct", "peak_tilt_deg", "diverged", "steady_offset_m")

#: The stated numbers an older certificate may lack; :meth:`ReferenceRun.differences` compares them when stated.
LATER_RUN_METRICS = ("steady_offset_m",)

#: The tolerance (a key of the certificate's ``tolerances``) each stated number is re-simulated within.
METRIC_TOLERANCES: Mapping[str, str] = MappingProxyType(
    {"settling_s": "settling_abs_s", "overshoot_pct": "overshoot_abs_pct", "peak_tilt_deg": "tilt_abs_deg",
     "steady_offset_m": "offset_abs_m"})


def run_metrics(metrics: Metrics) -> dict[str, Any]:
    """The stated numbers (:data:`RUN_METRICS`) of a run's metrics, as a certificate records them.

    Parameters
    ----------
    metrics
        The metrics of one run (:meth:`nniquad.sim.Trajectory.metrics`).
    """
    return {k: getattr(metrics, k) for k in RUN_METRICS}


@dataclass(frozen=True)
class ReferenceRun:
    """One reference run of a certificate: what flies, with which options, and what the certificate states of it.

    ``nniquad.simulate(**run.kwargs())`` (or :meth:`simulate`) flies it.

    Attributes
    ----------
    vehicle
        The certified vehicle.
    gains
        The certified gains (their type is the law).
    options
        The complete simulation options: model, inner loops, rate and controller sampling, motor lag, start,
        horizon, tilt limit, step and output period.
    stated
        The numbers the certificate states of the run (:data:`RUN_METRICS`); ``None`` for a run built, not read.
    """

    vehicle: Vehicle
    gains: GainBlock
    options: SimOptions
    stated: Mapping[str, Any] | None = None

    @property
    def model(self) -> str:
        """``"reduced"`` or ``"full"``."""
        return self.options.model

    @property
    def inner(self) -> InnerLoopGains:
        """The inner-loop gains the run flies with."""
        return self.options.inner

    def kwargs(self) -> dict[str, Any]:
        """``{"vehicle", "gains", "options"}``: the arguments of :func:`nniquad.sim.simulate` that fly the run."""
        return {"vehicle": self.vehicle, "gains": self.gains, "options": self.options}

    def simulate(self, progress: Callable[[float], None] | None = None) -> SimulationResult:
        """Fly the run (one trajectory).

        Parameters
        ----------
        progress
            Called with the completed fraction.
        """
        return simulate(self.vehicle, self.gains, self.options, progress=progress)

    def differences(self, got: Mapping[str, Any], tolerances: Mapping[str, float]) -> list[str]:
        """The stated numbers that ``got`` does not reproduce within ``tolerances`` (empty: reproduced).

        Parameters
        ----------
        got
            The re-simulated numbers (:func:`run_metrics`).
        tolerances
            The certificate's ``tolerances`` (:data:`METRIC_TOLERANCES` names the key of each number).
            A number of :data:`LATER_RUN_METRICS` that the certificate does not state is not compared (an older
            certificate; ``verify``'s tolerance check ties its absence to the older tolerances).
        """
        stated = self.stated or {}
        bad = []
        for key, tkey in METRIC_TOLERANCES.items():
            if key in LATER_RUN_METRICS and key not in stated:
                continue
            want, have = stated.get(key), got.get(key)
            if want is None or have is None:
                same = want is None and have is None
            else:
                same = (isinstance(want, (int, float)) and not isinstance(want, bool)
                        and abs(float(want) - float(have)) <= float(tolerances[tkey]))
            if not same:
                bad.append(key)
        if stated.get("diverged") is not bool(got.get("diverged")):
            bad.append("diverged")
        return bad

    def with_(self, vehicle: Vehicle | None = None, **changes: Any) -> "ReferenceRun":
        """A copy flown on another vehicle and/or with some options changed; it is no longer the certificate's run,
        so it states nothing (``stated`` is ``None``).

        Parameters
        ----------
        vehicle
            Another vehicle (``None``: the same).
        changes
            Fields of :class:`nniquad.sim.SimOptions`.
        """
        return replace(self, vehicle=self.vehicle if vehicle is None else vehicle, options=self.options.with_(**changes),
                       stated=None)


def reference_run_of(cert: Any, model: str = "full") -> ReferenceRun:
    """The reference run ``performance.<model>`` of a certificate, as its builder flew it.

    The options are read back from the run's recorded ``settings`` (the complete
    :class:`nniquad.sim.SimOptions` the builder simulated with); the inner loops are the
    certificate's ``inner_loop`` (``verify`` checks that the recorded ones equal them). A
    setting the record lacks (a certificate written before it existed) takes its
    :class:`~nniquad.sim.SimOptions` default, which is what that builder flew.

    Parameters
    ----------
    cert
        A :class:`nniquad.certificates.certificate.Certificate` (this module is below it: the certificate's
        :meth:`~nniquad.certificates.certificate.Certificate.run_settings` calls this function).
    model
        ``"full"`` (default) or ``"reduced"``.

    Raises
    ------
    CertificateError
        One line: the certificate has no such run, or its settings are not options of a run.
    """
    run = cert.performance.get(model) if isinstance(cert.performance, Mapping) else None
    if not isinstance(run, Mapping) or not isinstance(run.get("settings"), Mapping):
        raise CertificateError(f"certificate performance.{model} is missing or has no settings: its reference run "
                               "cannot be flown again")
    settings = {k: v for k, v in run["settings"].items() if k != "inner"}
    try:
        opts = SimOptions(**{**settings, "xi0": tuple(settings.get("xi0", cert.xi0_m)),
                             "zc0": tuple(settings.get("zc0", (0.0, 0.0))),
                             "wind_N": tuple(settings.get("wind_N", (0.0, 0.0))), "inner": cert.inner_loop})
    except (TypeError, NniquadError) as exc:
        raise CertificateError(f"certificate performance.{model}.settings: {exc}") from None
    stated = {k: run.get(k) for k in RUN_METRICS if k in run or k not in LATER_RUN_METRICS}  # older: no offset
    return ReferenceRun(cert.vehicle, cert.gains, opts, stated=MappingProxyType(stated))
