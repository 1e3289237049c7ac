"""Whether the reference start is certified, method by method: the certificate's ``start`` section.

A certificate states two regions of attraction, by two methods on two models: the reduced loop's ellipsoid
(``region_of_attraction``: the quadratic LMI under the norm tilt limit, continuous time, nominal vehicle) and, in
schema 2, the sampled-data cascade's region over the parameter box (``cascade.region_of_attraction``: the Lur'e
region, or the linear zone of the grid-checked Lyapunov matrix when no Lur'e region applies).  The start can lie in
one and not the other, so one word cannot say "certified" for both.  The ``start`` section states each::

    "start": {"distance_m": 2.5,
              "methods": {"reduced_loop": {"model": ..., "method": "quadratic_roa_lmi", "reach_m": 5.48, "inside": true},
                          "cascade": {"model": ..., "method": "linear_zone", "reach_m": 0.22, "inside": false}},
              "every_method": false}

and the top-level ``start_certified`` of a certificate with this section is ``every_method``: true only when every
method it names covers the start.  A certificate written before the section existed has none; its
``start_certified`` states the reduced-loop ellipsoid only (what it always meant), and :func:`start_methods`
derives the per-method view from its sections, so that every command reads both kinds the same way.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from nniquad.certificates.check_record import Check, thaw_json
from nniquad.certificates.integral import NOT_APPLICABLE

if TYPE_CHECKING:
    from nniquad.certificates.certificate import Certificate

__all__ = ["REDUCED_LOOP", "CASCADE", "REDUCED_LOOP_METHOD", "METHOD_MODELS", "start_section", "start_methods",
           "start_claim", "lure_fallback_reason", "start_lines", "start_check"]

#: The key of the reduced loop's region in ``start.methods``.
REDUCED_LOOP = "reduced_loop"
#: The key of the sampled-data cascade's region in ``start.methods``.
CASCADE = "cascade"
#: The method of the reduced loop's region (``lmi.region_of_attraction``).
REDUCED_LOOP_METHOD = "quadratic_roa_lmi"
#: The model each method's region is certified on (stated beside it).
METHOD_MODELS: dict[str, str] = {
    REDUCED_LOOP: "continuous reduced horizontal loop, nominal vehicle, norm tilt limit",
    CASCADE: "sampled-data cascade over the parameter box, norm tilt limit",
}


def _entry(key: str, method: Any, reach: Any, distance: float) -> dict[str, Any]:
    inside = isinstance(reach, (int, float)) and not isinstance(reach, bool) and distance <= float(reach)
    return {"model": METHOD_MODELS[key], "method": method, "reach_m": reach, "inside": bool(inside)}


def start_section(xi0_m: Sequence[float], region_of_attraction: Mapping[str, Any],
                  cascade: Mapping[str, Any] | None) -> dict[str, Any]:
    """The ``start`` section of a certificate, from its start and its stated regions.

    ``build_certificate`` writes it and ``verify`` rebuilds it from the stated reaches (which its region checks
    recompute) and compares: the two must be equal.

    Parameters
    ----------
    xi0_m
        The reference start [m].
    region_of_attraction
        The reduced loop's ``region_of_attraction`` section (one that is not applicable, of a law with integral
        action, names no method: :mod:`nniquad.certificates.integral`).
    cascade
        The ``cascade`` section, or ``None`` (schema 1: the reduced loop is the only method).
    """
    distance = math.hypot(*(float(v) for v in xi0_m))
    methods = {}
    if NOT_APPLICABLE not in region_of_attraction:  # a law with integral action has no reduced-loop region
        methods[REDUCED_LOOP] = _entry(REDUCED_LOOP, REDUCED_LOOP_METHOD,
                                       region_of_attraction.get("max_displacement_m"), distance)
    if cascade is not None:
        roa = cascade.get("region_of_attraction")
        roa = roa if isinstance(roa, Mapping) else {}
        methods[CASCADE] = _entry(CASCADE, roa.get("method"), roa.get("max_displacement_m"), distance)
    return {"distance_m": distance, "methods": methods,
            "every_method": all(m["inside"] for m in methods.values())}


def start_methods(cert: "Certificate") -> dict[str, Any]:
    """The certificate's ``start`` section, stated or (a certificate from before it existed) derived.

    Parameters
    ----------
    cert
        The certificate.
    """
    if cert.start is not None:
        return {"distance_m": cert.start["distance_m"], "every_method": cert.start["every_method"],
                "methods": {k: dict(v) for k, v in cert.start["methods"].items()}}
    return start_section(cert.xi0_m, cert.region_of_attraction, cert.cascade)


def start_claim(cert: "Certificate") -> str:
    """What the top-level ``start_certified`` refers to, in words (a certificate with a ``start`` section: every
    method it names; one without: the reduced-loop ellipsoid only).

    Parameters
    ----------
    cert
        The certificate.
    """
    if cert.start is not None:
        return "every method of 'start' (" + ", ".join(cert.start["methods"]) + ")"
    return f"the {REDUCED_LOOP} region only (a certificate from before the per-method 'start' section)"


def lure_fallback_reason(cert: "Certificate") -> str | None:
    """Why the cascade region is the linear zone and not the Lur'e region (one clause), or ``None`` when it is not
    (the Lur'e region, or no cascade section).

    Parameters
    ----------
    cert
        The certificate.
    """
    roa = cert.cascade.get("region_of_attraction") if cert.cascade is not None else None
    if not isinstance(roa, Mapping) or roa.get("method") != "linear_zone":
        return None
    law = cert.gains.law
    search = roa.get("lure_search")
    if search is None and not law.starts_at_zero(cert.gains, cert.vehicle.m):
        # the release that issued it solved the region for a start with the controller state 0 only
        return (f"the Lur'e region was solved for a start with the controller state 0 when this certificate was "
                f"issued, and the {law.name} law starts with its {law.start_description}, so it was not tried")
    status = search.get("solver_status") if isinstance(search, Mapping) else None
    return ("no Lur'e region passed every check and reached beyond the linear zone"
            + (f" (search: {status})" if status else ""))


def start_lines(cert: "Certificate", fmt_m) -> list[str]:
    """The lines ``certify`` prints about the start: one per method (its model, method, reach and verdict), then the
    top-level verdict naming what it covers; no line claims more than another states.

    Parameters
    ----------
    cert
        The certificate.
    fmt_m
        Formats a length in metres (``nniquad.format.fmt`` with the unit).
    """
    st = start_methods(cert)
    d = fmt_m(st["distance_m"])
    lines = []
    for key, m in st["methods"].items():
        verdict = "inside" if m["inside"] else "NOT inside"
        lines.append(f"start {d} {verdict} the {key} region ({m['method']}): reach {fmt_m(m['reach_m'])}")
    every = all(m["inside"] for m in st["methods"].values())
    names = ", ".join(st["methods"])
    lines.append(f"start certified by every method ({names}): {'yes' if every else 'no'}")
    return lines


def _method_text(key: str, m: Mapping[str, Any], distance: float) -> str:
    reach = m.get("reach_m")
    r = f"{float(reach):.4g} m" if isinstance(reach, (int, float)) and not isinstance(reach, bool) else repr(reach)
    return f"{key} ({m.get('method')}) reach {r} {'covers' if m.get('inside') else 'does NOT cover'} the start"


def start_check(cert: "Certificate") -> Check:
    """The ``start`` section rebuilt from the stated start and regions (whose reaches the region checks recompute),
    and ``start_certified`` against it: ``ok`` when the statement is exact, ``requirement_met`` when the start lies
    in every region.  A certificate without the section is checked for what its ``start_certified`` meant: the
    reduced loop's region only.

    Parameters
    ----------
    cert
        The certificate.
    """
    fresh = start_section(cert.xi0_m, cert.region_of_attraction, cert.cascade)
    per_method = "; ".join(_method_text(k, m, fresh["distance_m"]) for k, m in fresh["methods"].items())
    every = fresh["every_method"]
    if cert.start is None:
        reduced = fresh["methods"][REDUCED_LOOP]["inside"]
        ok = cert.start_certified is reduced
        return Check("start", ok, f"start {fresh['distance_m']:.4g} m: {per_method}; start_certified = "
                                  f"{cert.start_certified} states {start_claim(cert)}", requirement_met=every)
    ok = thaw_json(cert.start) == fresh and cert.start_certified is every
    return Check("start", ok, f"start {fresh['distance_m']:.4g} m: {per_method}; start_certified = "
                              f"{cert.start_certified} (every method: {every})"
                 + ("" if thaw_json(cert.start) == fresh else "; the stated 'start' section differs from the "
                                                               "one rebuilt from the stated regions"),
                 requirement_met=every)
