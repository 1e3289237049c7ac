"""Two laws side by side: the figures of the paper's law and of a certified law, each computed by code.

A column is a plain mapping (JSON ready) of one law's figures: the reference runs' settling, overshoot and peak tilt
on the ``reduced`` and ``full`` models, the classical margins at each break point with the failing one named, the
DC loop gain against the sector bound, and the reach of each certified region with whether it covers the start.
:func:`certificate_column` reads them from a certificate (whose numbers ``verify`` recomputes);
:func:`computed_column` computes them for gains that have no certificate (the paper's), with the certificate's
reference-run settings, margins and reduced-loop region (no cascade section is built for them: its region is
stated as not computed, never as certified).  :func:`comparison_table` lays the columns side by side.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

from nniquad.analysis.lmi import certified_reach
from nniquad.analysis.reduced_loop import reduced_loop
from nniquad.certificates.build import margins_section, performance_runs
from nniquad.certificates.certificate import Certificate
from nniquad.certificates.start import CASCADE, REDUCED_LOOP, start_methods
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.format import fmt, margin_text, margin_verdict
from nniquad.laws.base import GainBlock, gains_text
from nniquad.laws.classes import within_sector_bound
from nniquad.model.vehicle import Vehicle

__all__ = ["certificate_column", "computed_column", "comparison_table", "RUN_FIGURES"]

#: The reference runs' figures of a column (key, label, unit).
RUN_FIGURES = (("settling_s", "settling", "s"), ("overshoot_pct", "overshoot", "%"), ("peak_tilt_deg", "peak tilt", "deg"))


def _runs(perf: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    return {model: {k: perf[model][k] for k, _, _ in RUN_FIGURES} for model in ("reduced", "full")}


def _margins(section: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    req = section["required"]
    return {name: {"text": margin_text(p["gm_db"], p["gm_lower_db"], p["pm_deg"]),
                   "verdict": margin_verdict(p, req["gm_db"], req["pm_deg"])}
            for name, p in section["break_points"].items()}


def certificate_column(cert: Certificate) -> dict[str, Any]:
    """A certified law's figures, as its certificate states them.

    Parameters
    ----------
    cert
        The certificate.
    """
    start = start_methods(cert)
    return {
        "law": cert.controller, "gains": gains_text(cert.gains, sep=", ", number=_number), "source": f"certificate {cert.signature[:12]}",
        "runs": _runs(cert.performance),
        "margins": _margins(cert.margins) if cert.margins is not None else {},
        # an integral law's sector section is not applicable (C(0) is infinite): no gamma, no bound
        "gamma": cert.sector.get("gamma"),
        "within_sector_bound": (within_sector_bound(cert.sector["gamma"], cert.sector["gamma_max"])
                                if "gamma" in cert.sector else None),
        "regions": {k: {"method": m["method"], "reach_m": m["reach_m"], "inside": m["inside"]}
                    for k, m in start["methods"].items()},
        "start_m": start["distance_m"],
    }


def _gamma_cell(column: Mapping[str, Any]) -> str:
    """The DC loop gain and the sector verdict of a column, or why it has none (integral action)."""
    if column["gamma"] is None:
        return "not applicable (integral action: C(0) is infinite)"
    return f"{fmt(column['gamma'])} ({'within' if column['within_sector_bound'] else 'outside'} the sector bound)"


def computed_column(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, *, tilt_limit_deg: float,
                    gamma_max: float, xi0: Sequence[float], rate_hz: float, horizon_s: float) -> dict[str, Any]:
    """The figures of gains without a certificate, computed as a certificate's are (its reference runs, margins and
    reduced-loop region), over a horizon long enough for a slow law; the cascade region is not computed.

    Parameters
    ----------
    vehicle, gains, inner
        The design.
    tilt_limit_deg, gamma_max, xi0, rate_hz
        The certificate's settings to compute them with.
    horizon_s
        Horizon of the reference runs [s] (the paper's law settles in minutes).
    """
    loop = reduced_loop(vehicle, gains)
    reach = certified_reach(loop, tilt_limit_deg) if loop.smallest_gamma < 1 else 0.0
    start = math.hypot(*(float(v) for v in xi0))
    regions: dict[str, dict[str, Any]] = {REDUCED_LOOP: {"method": "quadratic_roa_lmi", "reach_m": reach,
                                                         "inside": start <= reach},
                                          CASCADE: {"method": "not computed", "reach_m": None, "inside": None}}
    return {
        "law": gains.controller, "gains": gains_text(gains, sep=", ", number=_number), "source": "computed by the report (no certificate)",
        "runs": _runs(performance_runs(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, xi0=xi0,
                                       horizon_s=horizon_s, rate_hz=rate_hz)),
        "margins": _margins(margins_section(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, gamma_max=gamma_max,
                                            rate_hz=rate_hz)),
        "gamma": loop.smallest_gamma, "within_sector_bound": within_sector_bound(loop.smallest_gamma, gamma_max),
        "regions": regions, "start_m": start,
    }


def _region_cell(r: Mapping[str, Any]) -> str:
    if r["reach_m"] is None:
        return r["method"]
    return f"{fmt(r['reach_m'], 'm')} ({r['method']}): start {'inside' if r['inside'] else 'NOT inside'}"


def comparison_table(columns: Mapping[str, Mapping[str, Any]]) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the side-by-side table: one row per figure, one column per law.

    Parameters
    ----------
    columns
        Title -> a column of :func:`certificate_column` or :func:`computed_column`.
    """
    cols = list(columns.values())
    rows = [["law", *[c["law"] for c in cols]], ["gains", *[c["gains"] for c in cols]],
            ["figures from", *[c["source"] for c in cols]]]
    for model in ("reduced", "full"):
        for key, label, unit in RUN_FIGURES:
            rows.append([f"{label} ({model})", *[fmt(c["runs"][model][key], unit, none="did not settle")
                                                 if key == "settling_s" else fmt(c["runs"][model][key], unit)
                                                 for c in cols]])
    points = list(dict.fromkeys(p for c in cols for p in c["margins"]))
    for p in points:
        rows.append([f"margins ({p})", *[(f"{c['margins'][p]['text']}: {c['margins'][p]['verdict']}"
                                          if p in c["margins"] else "-") for c in cols]])
    rows.append(["DC loop gain gamma", *[_gamma_cell(c) for c in cols]])
    for key in (REDUCED_LOOP, CASCADE):
        rows.append([f"certified reach, {key} region",
                     *[_region_cell(c["regions"][key]) if key in c["regions"] else "-" for c in cols]])
    return ["figure", *columns], rows


def _number(v: float) -> str:
    return fmt(v, digits=4)
