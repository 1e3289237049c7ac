"""The job ``report``: the whole design study of one vehicle in one folder."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from nniquad.config import GAMMA_MAX
from nniquad.errors import CertificateError
from nniquad.jobs.report_sections import ReportOptions, build_report
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle

__all__ = ["Report", "report"]


@dataclass(frozen=True)
class Report:
    """A finished report folder (see :func:`report`).

    Attributes
    ----------
    out_dir
        The folder.
    data
        The content of its ``report.json``: every number ``report.md`` prints.
    """

    out_dir: Path
    data: dict[str, Any]

    @property
    def files(self) -> list[Path]:
        """The files of the report."""
        return [self.out_dir / name for name in self.data["files"]]

    @property
    def digest(self) -> str:
        """SHA-256 digest of the certificate in the folder."""
        return self.data["certified"]["digest"]

    def __repr__(self) -> str:
        c = self.data["certified"]
        full = c["performance"]["full"]["settling_s"]
        return (f"Report({str(self.out_dir)!r}, {len(self.data['files'])} files, certified kp={c['gains']['kp']:.4g}, "
                f"full settling {'-' if full is None else f'{full:.4g} s'}, digest={self.digest[:16]}...)")

    def to_json(self) -> dict[str, Any]:
        """The content of ``report.json``."""
        return self.data


def report(out_dir: str | Path = "out", vehicle: Vehicle | None = None, *, model: str = "full",
           gamma_max: float = GAMMA_MAX, roa_radius_m: float | None = None, budget: str = "normal",
           reruns: int | None = 1, objective: str | None = None, law_class: str = "paper",
           certificate: str | Path | None = None, progress: Callable[..., None] | None = None) -> Report:
    """Run the main job: audit, bound, paper-gain runs, tuning, certificate, verification, figures, report.md.

    Parameters
    ----------
    out_dir
        Folder of the results (created if needed; an earlier report there is replaced).
    vehicle
        The vehicle; default the paper's.
    model
        Model the certified gains are tuned on (``"full"`` or ``"reduced"``).
    gamma_max
        Sector-bound ceiling in (0, 1).
    roa_radius_m
        Certified reach the tuner demands [m]; ``None`` is ``‖ξ_h(0)‖``, 0 switches it off.
    budget
        Tuning budget (``"quick"``, ``"normal"``, ``"thorough"``).
    reruns
        Extra tuner seeds for the grid-artefact check.
    objective
        ``"robust"`` (default for ``full``) or ``"nominal"`` (:class:`nniquad.tuning.tune.TuneOptions`).
    law_class
        ``"paper"`` (default) or ``"cascade"`` (:mod:`nniquad.laws.classes`): the class
        the design is tuned in and certified as; the report names the theorem.
    certificate
        An issued certificate file: report on it instead of tuning and certifying (it is
        verified, and its vehicle is the report's; ``vehicle`` must then be ``None``).
    progress
        Called as ``progress(stage, fraction, detail="")``.

    Returns
    -------
    Report
        The folder and every number of ``report.json``.
    """

    if certificate is not None and vehicle is not None:

        raise CertificateError("a report on a given certificate is of the certificate's vehicle: give no vehicle")
    vehicle = PAPER_VEHICLE if vehicle is None else vehicle
    options = ReportOptions(out_dir=Path(out_dir), model=model, gamma_max=gamma_max, roa_radius_m=roa_radius_m,
                            budget=budget, reruns=reruns, objective=objective, law_class=law_class,
                            certificate=None if certificate is None else Path(certificate))
    data = build_report(vehicle, options, progress=progress)
    return Report(Path(out_dir), data)
