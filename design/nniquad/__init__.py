"""nniquad: velocity-free quadrotor position control by nonlinear negative-imaginary theory.

A design study of Ghallab & Petersen's paper made into a library a control
engineer can check: the vehicle model derived with sympy, an audit of every
claim of the paper, the NI and stability LMIs (cvxpy + Clarabel, re-checked
with numpy), simulation of the reduced and full vehicle (CasADi), tuning under
the sector bound, certificates anyone can verify, and Monte Carlo studies.

Use it as python-control is used::

    import nniquad as nq

    tuned = nq.tune(nq.PAPER_VEHICLE, nq.TuneOptions(model="reduced"))
    cert = nq.certify(nq.PAPER_VEHICLE, tuned.gains)
    print(nq.verify(cert))

Every job is one function returning a result object with a readable
``repr`` and ``to_json()``: :func:`derive`, :func:`audit`, :func:`lmis`,
:func:`bound`, :func:`simulate`, :func:`tune`, :func:`certify`,
:func:`verify`, :func:`simulate_certificate` (a certificate's reference run,
:meth:`~nniquad.certificates.certificate.Certificate.run_settings`), :func:`montecarlo`, :func:`report`.  The command line
(``nniquad --help``) calls exactly these functions.

Names are loaded on first use (PEP 562), so ``import nniquad`` stays cheap:
sympy, CasADi and cvxpy are imported only by the jobs that need them.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

#: public name -> (module, attribute)
_API: dict[str, tuple[str, str]] = {}


def _export(module: str, *names: str, **renamed: str) -> None:
    for n in names:
        _API[n] = (module, n)
    for public, attr in renamed.items():
        _API[public] = (module, attr)


# core objects
_export("nniquad.model.vehicle", "Vehicle", "PAPER_VEHICLE", "load_vehicle")
_export("nniquad.laws", "Gains", "PAPER_GAINS", "PDGains", "PDFilteredGains", "SNI2Gains", "DEFAULT_TAU_F_S",
        "ControlLaw", "LAWS", "law_named", "register", "LAW_CLASSES", "DEFAULT_LAW_CLASS", "LawClass")
_export("nniquad.control.inner_gains", "InnerLoopGains", "DEFAULT_INNER_LOOP_GAINS")
_export("nniquad.tuning.vehicle_limits", "gain_limits")
_export("nniquad.analysis.fast_margins", "design_margins", "margin_shortfall")
_export("nniquad.laws.pd_filtered", "nni_from_filtered_pd", "filtered_pd_from_nni", "nni_start_state",
        "filtered_pd_gamma", "filtered_pd_in_sector")
_export("nniquad.certificates.certificate", "Certificate", "read_certificate", "write_certificate")
_export("nniquad.certificates.verify", "Verification", "Check")
_export("nniquad.certificates.reference_run", "ReferenceRun")
_export("nniquad.analysis.reduced_loop", "ReducedLoop", "PolesDamping")
_export("nniquad.sim", "SimOptions", "SimulationResult", "Trajectory", "paper_figure_runs", "PAPER_FIGURE_HORIZON_S")
_export("nniquad.control.references", "Reference", "Circle", "FigureEight", "MinimumJerk", "SetpointSteps",
        "TimeShifted")
_export("nniquad.control.reference_files", "parse_reference")
_export("nniquad.tuning.tune", "TuneOptions", "TuneResult", "search_box", "decode", "encode",
        "attitude_accel_headroom", "attitude_wn_cap", "required_hold_s", "settling_shown", "TILT_SLACK_DEG")
_export("nniquad.study", "ScenarioRanges", "DEFAULT_RANGES", "StudySetup", "study_setup_from", "pareto_front")
# one function per job, and its result object
_export("nniquad.model.derivation", "derive", "Derivation")
_export("nniquad.proofs.audit", "audit", "Audit")
_export("nniquad.analysis.lmi.overview", "lmis", "LMIReport")
_export("nniquad.analysis.bound", "BoundResult", "max_horizontal_acceleration", bound="time_optimal_bound")
_export("nniquad.sim", "simulate")
_export("nniquad.tuning.tune", "tune")
_export("nniquad.jobs.certify", "certify", "verify")
_export("nniquad.jobs.certificate_run", "simulate_certificate")
_export("nniquad.jobs.montecarlo", "montecarlo", "MonteCarloResult")
_export("nniquad.jobs.report", "report", "Report")
# the LMIs and metrics a notebook calls directly
_export("nniquad.analysis.lmi", "LMIResult", "region_of_attraction", "axis_acceleration_limit", "certified_reach",
        "closed_loop_decay", "robust_mass_decay")
_export("nniquad.sim.metrics", "settling_time", "settling_time_batch", "overshoot_pct", "tilt_deg", "rms_after")
_export("nniquad.sim.verdicts", "Metrics", "compute_metrics")
# figures and tables (matplotlib and IPython are imported only when these are used)
_export("nniquad.sim.plots", "paper_figure", "trajectory_plot")
_export("nniquad.reporting.display", "show_figure", "show_table", "markdown_table", "notebook_size", "sized")
_export("nniquad.reporting.notebooks", "notebook_vehicle", "notebook_data", "notebook_certificate")
_export("nniquad.format", "fmt")
_export("nniquad.progress", "Progress")
# errors, by kind
_export("nniquad.errors", "NniquadError", "VehicleError", "GainError", "SolverError", "CertificateError",
        "SimulationError", "MonteCarloError")
# defaults (nniquad.config)
_export("nniquad.config", "XI0_M", "TILT_LIMIT_DEG", "BAND_FRACTION", "GAMMA_MAX")

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    try:
        module, attr = _API[name]
    except KeyError:
        raise AttributeError(f"module 'nniquad' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value  # cache: the next access is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
