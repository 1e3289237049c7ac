"""Re-checks that re-run something: the classical margins of the cascade and the two reference flights.

A margin verdict ("meets the required margin") is recomputed and compared
within the stated tolerances, never bit for bit; the reference runs are
re-simulated as their builder flew them
(:meth:`nniquad.certificates.certificate.Certificate.run_settings`).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from nniquad.certificates.build import MARGIN_FIELDS, margins_section, sector_pm_ceiling_deg
from nniquad.certificates.certificate import Certificate
from nniquad.certificates.check_record import Check, close, fmt_value, gains_key, memo
from nniquad.certificates.integral import NOT_APPLICABLE
from nniquad.certificates.reference_run import LATER_RUN_METRICS, METRIC_TOLERANCES, run_metrics
from nniquad.config import GAMMA_MAX
from nniquad.errors import CertificateError
from nniquad.format import margin_text, margin_verdict

__all__ = ["same_margin", "meets_within", "margins_check", "performance_check"]


def same_margin(stated: Any, computed: Any, tol: float, relative: bool = False) -> bool:
    """A stated margin number (or ``"inf"``/``"-inf"``/``"nan"`` string, or bool) against the recomputed one."""
    if isinstance(computed, bool) or isinstance(stated, bool):
        return stated is computed
    if isinstance(computed, str) or isinstance(stated, str):
        return isinstance(stated, str) and isinstance(computed, str) and stated == computed
    if not isinstance(stated, (int, float)):
        return False
    err = abs(float(stated) - float(computed))
    return err <= (tol * max(abs(float(computed)), 1e-12) if relative else tol)


def meets_within(stated: Any, comp: Mapping[str, Any], required: Mapping[str, float],
                  tol: Mapping[str, float]) -> bool:
    """A stated ``meets_requirement`` against the recomputed margins, judged within the margins' tolerances.

    A verdict is a threshold on numbers that ``verify`` compares only within ``margin_db_abs`` and
    ``margin_deg_abs``: a margin within that of its requirement may be computed on either side of it on another
    machine, so either verdict is accepted there, and only there.  ``True`` needs every margin to reach its
    requirement less the tolerance (on a stable loop); ``False`` needs one margin short of it by more than the
    tolerance, or an unstable loop.
    """
    if not isinstance(stated, bool):
        return False
    if comp.get("stable") is not True:
        return stated is False
    gm_req, pm_req = float(required["gm_db"]), float(required["pm_deg"])
    shortfalls = (  # how far each requirement is missed (negative: met with room)
        (gm_req - float(comp["gm_db"]), tol["margin_db_abs"]),
        (float(comp["gm_lower_db"]) + gm_req, tol["margin_db_abs"]),
        (pm_req - float(comp["pm_deg"]), tol["margin_deg_abs"]),
    )
    shortfalls = tuple((math.inf if math.isnan(short) else short, t) for short, t in shortfalls)  # nan: not met
    if stated:
        return all(short <= t for short, t in shortfalls)
    return any(short > -t for short, t in shortfalls)


def margins_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    """Recompute the classical margins from the vehicle, the gains and the inner loops (never stored matrices)."""

    stated = cert.margins
    try:
        rate = float(stated["rate_hz"])
        # no sector bound without the paper's theorem (an integral law): its ceiling is 180 whatever gamma_max
        gamma_max = float(cert.sector["gamma_max"]) if NOT_APPLICABLE not in cert.sector else GAMMA_MAX
    except (KeyError, TypeError, ValueError):
        raise CertificateError("certificate 'margins' needs a number 'rate_hz'") from None
    if (stated.get("controller") != "discrete" or stated.get("pade_order") != 2
            or isinstance(stated.get("pade_order"), bool)):
        return Check("margins", False, "margins stated for another sampling model than the one recomputed")
    fresh = memo("margins", [cert.vehicle.as_dict(), gains_key(cert), cert.inner_loop.as_dict(),
                              cert.tilt_limit_deg, gamma_max, rate],
                  lambda: margins_section(cert.vehicle, cert.gains, cert.inner_loop,
                                          tilt_limit_deg=cert.tilt_limit_deg, gamma_max=gamma_max, rate_hz=rate))
    ok = True
    bad: list[str] = []
    points = stated.get("break_points")
    if not isinstance(points, Mapping) or set(points) != set(fresh["break_points"]):
        return Check("margins", False, "margins: the break points stated differ from the recomputed ones")
    for name, comp in fresh["break_points"].items():
        st = points[name]
        for key in MARGIN_FIELDS:
            if key == "meets_requirement":
                same = meets_within(st.get(key), comp, fresh["required"], tol)
            elif key.endswith("_db"):
                same = same_margin(st.get(key), comp[key], tol["margin_db_abs"])
            elif key.endswith("_deg"):
                same = same_margin(st.get(key), comp[key], tol["margin_deg_abs"])
            elif key.endswith("_rad_s"):
                same = same_margin(st.get(key), comp[key], tol["margin_freq_relative"], relative=True)
            else:
                same = same_margin(st.get(key), comp[key], 0.0)
            if not same:
                ok = False
                bad.append(f"{name}.{key} {st.get(key)!r} (recomputed {comp[key]!r})")
    # the overall verdict is the conjunction of the stated per-break-point verdicts (each checked above)
    ok = ok and stated.get("meets_requirement") is all(points[n].get("meets_requirement") is True for n in points)
    ok = ok and isinstance(stated.get("required"), Mapping) and dict(stated["required"]) == fresh["required"]
    ok = ok and close(stated.get("horizontal_pm_ceiling_deg"), sector_pm_ceiling_deg(gamma_max, cert.controller),
                       1e-12)
    req = fresh["required"]
    detail = "; ".join(f"{name} {margin_text(p['gm_db'], p['gm_lower_db'], p['pm_deg'])}: "
                       f"{margin_verdict(p, req['gm_db'], req['pm_deg'])}"
                       for name, p in fresh["break_points"].items()) + f" (at {rate:g} Hz)"
    if bad:
        detail += "; differs: " + ", ".join(bad[:3])
    return Check("margins", ok, detail, requirement_met=fresh["meets_requirement"])


def performance_check(cert: Certificate, tol: Mapping[str, float], model: str) -> Check:
    """Re-simulate one reference run with its stated settings (checked by ``settings``) and compare every number."""

    run = cert.run_settings(model)  # the run as its builder flew it (a certificate lacking it is refused in one line)
    stated, opts = cert.performance[model], run.options

    def run_() -> dict[str, Any]:
        return run_metrics(run.simulate()[0].metrics())

    got_all = memo("simulate", [cert.vehicle.as_dict(), gains_key(cert), opts.to_json()], run_)
    diffs = [f"{key} {fmt_value(got_all[key])} (stated {fmt_value(stated.get(key))})" for key in METRIC_TOLERANCES
             if key in stated or key not in LATER_RUN_METRICS]  # an older certificate states no steady offset
    diffs.append(f"diverged {bool(got_all['diverged'])} (stated {stated.get('diverged')!r})")
    ok = not run.differences(got_all, tol)
    return Check(f"performance.{model}", ok, ", ".join(diffs))
