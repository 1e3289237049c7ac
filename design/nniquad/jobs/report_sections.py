"""The main job: one folder with everything a control engineer needs.

:func:`build_report` runs, in order, the audit of the paper, the time-optimal
bound, the paper's gains on the three models, the tuner and the certificate
(with its independent verification), the certified gains on the three models,
and writes

``report.md``
    the audit table, the certified gain set with its verification table, the
    figures, the bound and the ratios to it, the key trade-off numbers;
``report.json``
    every number that ``report.md`` prints, under the same names (the test
    suite checks that the two agree);
``certificate.json``, ``audit.json``, ``audit.md``
    as written by ``nniquad certify`` and ``nniquad prove``;
``paper_gains.png``, ``certified_gains.png``
    x(t), y(t) on the ``linear``, ``reduced`` and ``full`` models.

``manifest.json``
    the SHA-256 of every file above (:mod:`nniquad.reporting.folder`).

With :attr:`ReportOptions.certificate` the report is of an issued certificate:
the tuner and the certificate builder are not run, the given certificate is
verified like an issued one and written as it was signed, and its vehicle is
the report's.

The folder is built beside the target and swapped in whole
(:class:`nniquad.reporting.folder.ReportFolder`): a second run into the same
folder replaces the old results cleanly, a failed or interrupted run leaves
the old folder as it was, a concurrent run into the same folder is refused,
and only files an earlier run wrote (listed with an unchanged digest in its
manifest) are ever deleted.  Every option is validated before any work.
Numbers in ``report.md`` are formatted by :func:`fmt` from the values stored
in ``report.json``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

from nniquad.analysis.bound import time_optimal_bound
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.certificates import (
    build_certificate,
    certificate_gains,
    certificate_inner_loop,
    certificate_vehicle,
    load_certificate,
    verify_certificate,
    write_certificate,
)
from nniquad.certificates.certificate import Certificate
from nniquad.certificates.start import start_methods
from nniquad.config import CONTROL_RATE_HZ, GAMMA_MAX
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS
from nniquad.errors import CertificateCheckError
from nniquad.io import atomic_write_json, atomic_write_text
from nniquad.laws.base import gains_text
from nniquad.laws.nni import PAPER_GAINS
from nniquad.model.vehicle import UNITS, Vehicle
from nniquad.proofs.claims import audit_table, audit_to_json, audit_to_markdown, run_audit
from nniquad.reporting.comparison import certificate_column, comparison_table, computed_column
from nniquad.reporting.display import markdown_table
from nniquad.reporting.folder import MANIFEST, ReportFolder
from nniquad.sim import SimOptions, paper_figure_runs, plots
from nniquad.tuning.tune import TuneOptions, tune

__all__ = ["ReportOptions", "build_report", "fmt", "REPORT_FILES", "REPORT_OUTPUTS"]

#: Files the report always writes (figures are added as they are made).
REPORT_FILES = ("report.md", "report.json", "certificate.json", "audit.json", "audit.md")
#: Every file a report folder can hold that nniquad writes (the figures and the manifest too).
REPORT_OUTPUTS = REPORT_FILES + ("paper_gains.png", "certified_gains.png", MANIFEST)

Progress = Callable[..., None]


def fmt(value: Any, digits: int = 4) -> str:
    """Format a number for the report: ``digits`` significant digits; ``None`` -> 'did not settle'."""
    if value is None:
        return "did not settle"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)):
        if not math.isfinite(float(value)):
            return str(value)
        return f"{float(value):.{digits}g}"
    return str(value)


@dataclass(frozen=True)
class ReportOptions:
    """Settings of :func:`build_report`.

    Parameters
    ----------
    out_dir
        Folder of the results (created if needed).
    model
        Model the certified gains are tuned on (``"full"`` or ``"reduced"``).
    gamma_max
        Sector-bound ceiling γ_max (the paper's 0.8).
    roa_radius_m
        Certified reach demanded by the tuner (None: ‖ξ_h(0)‖).
    paper_horizon_s
        Horizon of the paper-gain runs (long: the paper's loop settles in minutes).
    budget
        Tuning budget passed to the tuner (:data:`nniquad.tuning.tune.BUDGETS`).
    reruns
        Extra tuner seeds (None: 1, which keeps the report within its time budget).
    objective
        Tuning objective (:attr:`nniquad.tuning.tune.TuneOptions.objective`; ``None``:
        robust for ``full``, nominal for ``reduced``).
    law_class
        ``"paper"`` or ``"cascade"`` (:mod:`nniquad.laws.classes`); ``roa_radius_m``
        ``None`` demands ‖ξ_h(0)‖ in the paper class and nothing in the cascade class.
    certificate
        An issued certificate file to report on instead of tuning and certifying (``None``: tune and
        certify).  Its vehicle is the report's; it is verified like an issued one, and the tuning
        settings above do not apply.
    """

    out_dir: Path
    model: str = "full"
    gamma_max: float = GAMMA_MAX
    roa_radius_m: float | None = None
    paper_horizon_s: float = 300.0
    budget: str = "normal"
    reruns: int | None = 1
    objective: str | None = None
    law_class: str = "paper"
    certificate: Path | None = None


def _relative(out_dir: Path, path: Path) -> str:
    return str(Path(path).resolve().relative_to(out_dir.resolve()))


def _model_rows(runs: dict[str, Any]) -> dict[str, dict[str, Any]]:
    rows = {}
    for model, traj in runs.items():
        m = traj.metrics()
        rows[model] = {
            "settling_s": m.settling_s,
            "overshoot_pct": m.overshoot_pct,
            "peak_tilt_deg": m.peak_tilt_deg,
            "diverged": bool(m.diverged),
            "horizon_s": m.horizon_s,
            "steady_offset_m": m.steady_offset_m,
        }
    return rows


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    return markdown_table(header, rows).splitlines()


def _model_table(rows: dict[str, dict[str, Any]]) -> list[str]:
    body = [
        [model, fmt(r["settling_s"]), fmt(r["overshoot_pct"]), fmt(r["peak_tilt_deg"]), fmt(r["steady_offset_m"]),
         fmt(r["diverged"]), fmt(r["horizon_s"])]
        for model, r in rows.items()
    ]
    return _table(["model", "settling (s)", "overshoot (%)", "peak tilt (deg)", "steady offset (m)", "diverged",
                   "horizon (s)"], body)


def build_report(vehicle: Vehicle, options: ReportOptions, progress: Progress | None = None) -> dict[str, Any]:
    """Run the main job and write the report folder; return the content of ``report.json``.

    Raises
    ------
    nniquad.errors.NniquadError
        If the certificate cannot be issued (for example no admissible gain set)
        or does not verify; nothing of this run is left half-written.
    """

    say = progress or (lambda stage, frac, detail="": None)
    # every option first: a bad one is refused before any work (and before the folder is touched)
    given = given_check = None
    if options.certificate is not None:

        given = load_certificate(options.certificate)  # unreadable, not a certificate or tampered: one line
        vehicle = certificate_vehicle(given)
        # the input is checked first: a certificate that does not verify is refused before any other work
        say("verifying the given certificate independently", 0.0)
        given_check = _verified(given, "given")
    tune_opts = TuneOptions(model=options.model, gamma_max=options.gamma_max, roa_radius_m=options.roa_radius_m,
                            budget=options.budget, reruns=options.reruns, objective=options.objective,
                            law_class=options.law_class)
    reach = tune_opts.roa_radius_m
    SimOptions(horizon_s=options.paper_horizon_s)
    with ReportFolder(options.out_dir, REPORT_OUTPUTS) as folder:
        data = _build(vehicle, options, tune_opts, folder.path, say, given, given_check)
        folder.commit(data["files"])
    return data


def _verified(cert: dict[str, Any], which: str) -> Any:
    """``verify_certificate(cert)``; raises CertificateCheckError naming the failed checks when one fails."""

    check = verify_certificate(cert)
    if not check.ok:
        failed = [c.name for c in check.checks if not c.ok]
        raise CertificateCheckError(f"the {which} certificate does not verify: {', '.join(failed)}")
    return check


def _build(vehicle: Vehicle, options: ReportOptions, tune_opts: Any, out: Path, say: Progress,
           given: dict[str, Any] | None = None, given_check: Any = None) -> dict[str, Any]:
    """Run every step and write every file into ``out`` (the build folder); return ``report.json``'s content.

    ``given``: the certificate to report on (no tuning, no new certificate), else ``None``; ``given_check``: its
    verification.
    """

    t_start = time.perf_counter()
    written: list[Path] = []
    reach = tune_opts.roa_radius_m

    # 1. audit
    say("audit of the paper", 0.0)
    claims = run_audit()
    audit_json = audit_to_json(claims)
    written.append(atomic_write_json(out / "audit.json", audit_json))
    written.append(atomic_write_text(out / "audit.md", audit_to_markdown(claims)))
    verdict_counts: dict[str, int] = {}
    for c in claims:
        verdict_counts[c.verdict] = verdict_counts.get(c.verdict, 0) + 1

    # 2. bound
    say("time-optimal bound", 0.15)
    bound = time_optimal_bound(vehicle)

    # 3. the paper's gains
    say("paper's gains on the linear, reduced and full models", 0.2)
    pd = ReducedLoop.from_vehicle(vehicle, PAPER_GAINS).poles_and_damping()
    paper_runs = paper_figure_runs(vehicle, PAPER_GAINS, horizon_s=options.paper_horizon_s)
    written.append(plots.paper_figure(paper_runs, out / "paper_gains.png", title="Paper's gains (kp=5, Γ=160, δ=0.6)"))
    paper_rows = _model_rows(paper_runs)

    # 4. tune (with and without the certified-reach requirement) and certify, or take the given certificate
    free = tuned = None
    if given is None:
        stage = f"tuning on the {options.model} model (certified reach {fmt(reach)} m)"
        warm: list = []
        if reach > 0:
            # first without the requirement: its optimum is the reference for the cost of the
            # guarantee, and a warm start for the constrained search (used if it is admissible)
            free_stage = f"tuning on the {options.model} model without the reach requirement"
            free = tune(vehicle, replace(tune_opts, roa_radius_m=0.0), progress=lambda msg: say(free_stage, 0.3, msg))
            warm = [(free.gains, free.inner)]
        tuned = tune(vehicle, tune_opts, progress=lambda msg: say(stage, 0.55, msg), warm_starts=warm)
        say("building the certificate", 0.75)
        cert = build_certificate(vehicle, tuned.gains, gamma_max=options.gamma_max, inner=tuned.inner,
                                 tilt_limit_deg=tune_opts.tilt_limit_deg, model=options.model,
                                 law_class=options.law_class, rate_hz=tune_opts.rate_hz,
                                 tuning={"source": "nniquad report", **tuned.to_json()}).to_json()  # the JSON document
        say("verifying the certificate independently", 0.8)
        report_check = _verified(cert, "issued")
    else:
        cert, report_check = given, given_check
    written.append(write_certificate(cert, out / "certificate.json"))
    tradeoffs = _tradeoffs(tuned, free) if tuned is not None else []

    # 5. the certified gains on the three models
    say("certified gains on the three models", 0.9)
    gains = certificate_gains(cert)
    cert_horizon = float(cert["performance"]["full"]["settings"]["horizon_s"])
    cert_runs = paper_figure_runs(vehicle, gains, horizon_s=cert_horizon,
                                  options=SimOptions(inner=certificate_inner_loop(cert), motor_lag=True))
    written.append(plots.paper_figure(cert_runs, out / "certified_gains.png",
                                      title=f"Certified gains ({gains_text(gains, sep=', ', greek=True, number=fmt)})",
                                      zoom_s=min(10.0, cert_horizon)))
    cert_rows = _model_rows(cert_runs)

    # 5b. the paper's law and the certified law side by side, each figure computed (the paper's law has no
    # certificate: its figures are computed with the certificate's settings, over the paper runs' longer horizon)
    say("the paper's law beside the certified law", 0.95)
    typed = Certificate.from_json(cert)
    columns = {
        "paper's law": computed_column(
            vehicle, PAPER_GAINS, DEFAULT_INNER_LOOP_GAINS, tilt_limit_deg=typed.tilt_limit_deg,
            gamma_max=typed.sector.get("gamma_max", options.gamma_max), xi0=typed.xi0_m, horizon_s=options.paper_horizon_s,
            rate_hz=typed.cascade["rate_hz"] if typed.cascade is not None else CONTROL_RATE_HZ),
        "certified law": certificate_column(typed),
    }

    # 6. one JSON with every number the markdown prints
    perf = cert["performance"]
    data: dict[str, Any] = {
        "vehicle": vehicle.as_dict(),
        "thrust_to_weight": vehicle.thrust_to_weight(),
        "audit": {"claims": len(claims), "verdicts": verdict_counts},
        "bound": {"enter_band_s": bound.enter_band_s, "rest_to_rest_s": bound.rest_to_rest_s,
                  "a_max_m_s2": bound.a_max_m_s2},
        "paper_gains": {
            "gains": PAPER_GAINS.as_dict(),
            "poles": _unique_poles(pd.poles),
            "min_damping": float(pd.min_damping),
            "models": paper_rows,
        },
        "certified": {
            "gains": gains.as_dict(),
            "law": gains.controller,
            # every law's gains (the NNI law's kp, Gamma, delta; sni2's kp, k, omega, zeta), as report.md prints them
            "gains_text": gains_text(gains, sep=", ", number=fmt),
            "inner_loop": cert.get("inner_loop"),
            # None for an integral law: its sector and reduced-loop sections are not applicable
            "gamma": cert["sector"].get("gamma"),
            "gamma_max": cert["sector"].get("gamma_max"),
            "law_class": cert["law_class"],
            "start_certified": cert["start_certified"],
            "start": start_methods(typed),
            "max_displacement_m": cert["region_of_attraction"].get("max_displacement_m"),
            # the reach the tuner demanded; of a given certificate, its tuning record's (None: not recorded)
            "roa_radius_m": tuned.roa_radius_m if tuned is not None else (cert.get("tuning") or {}).get("roa_radius_m"),
            "performance": {k: {f: perf[k][f] for f in ("settling_s", "overshoot_pct", "peak_tilt_deg")} for k in ("reduced", "full")},
            "ratio_to_bound": cert["ratio_to_bound"],
            "models": cert_rows,
            "verification": report_check.to_json(),
            "digest": cert["digest"]["value"],
        },
        # a given certificate's tuning section is its record of how the gains were found (not re-run, not verified)
        "tuning": tuned.to_json() if tuned is not None else cert.get("tuning"),
        "comparison": columns,
        "tradeoffs": tradeoffs,
        "source": ("tuned and certified by this report" if given is None
                   else f"the given certificate {options.certificate} (verified; not tuned again)"),
    }
    data["wall_time_s"] = time.perf_counter() - t_start
    files = [_relative(out, p) for p in written] + ["report.md", "report.json", MANIFEST]
    data["files"] = sorted(set(files))

    md = _markdown(data, audit_table(claims), report_check.table())
    atomic_write_text(out / "report.md", md)
    atomic_write_json(out / "report.json", data)
    say("done", 1.0)
    return data


def _tradeoffs(tuned: Any, free: Any) -> list[dict[str, Any]]:
    """The key trade-off numbers of the tuning runs, each with a label and a unit."""
    rows = [
        {"label": f"Tuned settling time ({tuned.options.model} model, certified reach >= {fmt(tuned.roa_radius_m)} m)",
         "value": tuned.settling_s, "unit": "s"},
        {"label": "Its ratio to the time-optimal bound", "value": tuned.ratio_to_bound, "unit": "x"},
        {"label": "Its certified reach", "value": tuned.certified_reach_m, "unit": "m"},
        {"label": "Its peak actual tilt", "value": tuned.metrics.peak_tilt_deg, "unit": "deg"},
        {"label": "Spread of the per-seed optima (grid-artefact check)", "value": tuned.rerun_spread_s(), "unit": "s"},
    ]
    if free is not None:
        rows += [
            {"label": "Best settling time without the reach requirement", "value": free.settling_s, "unit": "s"},
            {"label": "Its ratio to the time-optimal bound", "value": free.ratio_to_bound, "unit": "x"},
            {"label": "Its certified reach", "value": free.certified_reach_m, "unit": "m"},
            {"label": "Settling time the reach guarantee costs", "value": tuned.settling_s - free.settling_s,
             "unit": "s"},
        ]
    return rows


def _unique_poles(poles: Any) -> list[list[float]]:
    """Poles of one axis (both axes share them when kp_x = kp_y), sorted, as [re, im] pairs."""
    seen: list[complex] = []
    for p in sorted((complex(q) for q in poles), key=lambda z: (z.real, z.imag)):
        if not any(abs(p - q) <= 1e-9 * max(1.0, abs(q)) for q in seen):
            seen.append(p)
    return [[p.real, p.imag] for p in seen]


def _markdown(d: dict[str, Any], audit_txt: str, verify_txt: str) -> str:
    v, b, pg, c = d["vehicle"], d["bound"], d["paper_gains"], d["certified"]
    lines = [
        "# nniquad design report",
        "",
        f"Vehicle: {v['name']}.",
        "",
        *_table(["parameter", "value", "unit"], [[k, fmt(val, 6), UNITS[k]] for k, val in v.items() if k != "name"]),
        "",
        f"Thrust-to-weight ratio: {fmt(d['thrust_to_weight'])}.",
        "",
        "## Audit of the paper",
        "",
        f"{d['audit']['claims']} claims checked: "
        + ", ".join(f"{n} {verdict}" for verdict, n in sorted(d["audit"]["verdicts"].items()))
        + ". Full evidence, counterexamples and corrections: `audit.md`, `audit.json`.",
        "",
        "```",
        audit_txt,
        "```",
        "",
        "## The physical limit",
        "",
        f"With the tilt limit the horizontal acceleration is at most {fmt(b['a_max_m_s2'])} m/s^2. "
        f"No controller can enter the settling band and stay there sooner than enter_band_s = {fmt(b['enter_band_s'])} s "
        f"(ending at rest: rest_to_rest_s = {fmt(b['rest_to_rest_s'])} s).",
        "",
        "## The paper's gains",
        "",
        f"kp = {fmt(pg['gains']['kp'])} 1/s^2, Gamma = {fmt(pg['gains']['Gamma'])}, delta = {fmt(pg['gains']['delta'])}. "
        f"Closed-loop poles (per axis): "
        + ", ".join(f"{fmt(re)}{'+' if im >= 0 else '-'}{fmt(abs(im))}j" for re, im in pg["poles"])
        + f" 1/s; smallest damping ratio {fmt(pg['min_damping'])}.",
        "",
        *_model_table(pg["models"]),
        "",
        "![paper gains](paper_gains.png)",
        "",
        "## The certified gain set",
        "",
        f"{c['law']} law, {c['gains_text']}; "
        + (f"smallest sector gamma = {fmt(c['gamma'])} (gamma_max = {fmt(c['gamma_max'])}). "
           if c["gamma"] is not None else "no sector gamma: integral action makes C(0) infinite, the sector theorem "
           "does not apply. ")
        + f"Law class **{c['law_class']['name']}**: certified by {c['law_class']['theorem']}. "
        + (f"Certified region of attraction of the reduced loop under the tilt limit: displacements from rest up to "
           f"{fmt(c['max_displacement_m'])} m " if c["max_displacement_m"] is not None
           else "The reduced loop's region of attraction is not applicable (integral action) ")
        + (f"(required: {fmt(c['roa_radius_m'])} m)" if c["roa_radius_m"] is not None else "(no reach recorded as required)")
        + "; the start " + "; ".join(f"{'inside' if m['inside'] else 'NOT inside'} the {k} region ({m['method']}, "
                                     f"reach {fmt(m['reach_m'])} m)" for k, m in c["start"]["methods"].items())
        + f"; start certified by every method: {fmt(c['start']['every_method'])}. Source: {d['source']}.",
        "",
        *_table(
            ["model", "settling (s)", "overshoot (%)", "peak tilt (deg)", "ratio to enter_band_s"],
            [[k, fmt(p["settling_s"]), fmt(p["overshoot_pct"]), fmt(p["peak_tilt_deg"]), fmt(c["ratio_to_bound"].get(k))]
             for k, p in c["performance"].items()],
        ),
        "",
        "![certified gains](certified_gains.png)",
        "",
        "### The paper's law beside the certified law",
        "",
        *_table(*comparison_table(d["comparison"])),
        "",
        "### Independent verification (`nniquad verify certificate.json`)",
        "",
        "```",
        verify_txt,
        "```",
        "",
        f"Certificate digest (SHA-256): `{c['digest']}`.",
        "",
        "## Key trade-off numbers",
        "",
        *_tradeoff_lines(d),
        "",
        f"Report built in {fmt(d['wall_time_s'], 3)} s.",
        "",
    ]
    return "\n".join(lines)


def _tradeoff_lines(d: dict[str, Any]) -> list[str]:
    c, pg, b = d["certified"], d["paper_gains"], d["bound"]
    paper_full = pg["models"].get("full", {})
    lines = [
        f"- Paper's gains: settling {fmt(pg['models']['linear']['settling_s'])} s on the linear model "
        f"({fmt(pg['models']['linear']['overshoot_pct'])} % overshoot); on the full vehicle: "
        f"{'diverged' if paper_full.get('diverged') else fmt(paper_full.get('settling_s'))}.",
        f"- Certified gains: settling {fmt(c['performance']['full']['settling_s'])} s on the full vehicle, "
        f"{fmt(c['ratio_to_bound'].get('full'))} x the time-optimal bound {fmt(b['enter_band_s'])} s.",
    ]
    for row in d["tradeoffs"]:
        lines.append(f"- {row['label']}: {fmt(row['value'])} {row.get('unit', '')}".rstrip())
    return lines
