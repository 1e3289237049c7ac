"""A study's setup from a certificate: the certified vehicle, gains, inner loops, start and region.

:func:`study_setup` reads a loaded certificate (a form-checked mapping, or a
:class:`nniquad.certificates.certificate.Certificate`) with the certificate's own
accessors and hands it to :func:`nniquad.scenarios.setup.study_setup_from`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Mapping

from nniquad.certificates.sections import certificate_gains, certificate_inner_loop, certificate_vehicle
from nniquad.config import BAND_FRACTION, TILT_LIMIT_DEG, XI0_M
from nniquad.errors import MonteCarloError
from nniquad.scenarios.ranges import DEFAULT_RANGES, ScenarioRanges, positive_number_or_none
from nniquad.scenarios.draws import Scenario
from nniquad.scenarios.draws import draw_scenarios as draw_setup_scenarios
from nniquad.scenarios.setup import DEFAULT_HORIZON_S, StudySetup, study_setup_from

__all__ = ["study_setup", "draw_scenarios"]


def _certificate_label(cert: Mapping[str, Any]) -> str:
    for key in ("digest", "sha256"):
        v = cert.get(key)
        if isinstance(v, Mapping):
            v = v.get("sha256") or v.get("value")
        if isinstance(v, str) and v:
            return f"sha256:{v[:16]}" if not v.startswith("sha256") else v[:23]
    return str(cert.get("name", ""))


def study_setup(cert: Mapping[str, Any] | StudySetup, ranges: ScenarioRanges = DEFAULT_RANGES, *,
                horizon_s: float | None = None, region_m: float | None = None) -> StudySetup:
    """The shared part of a study from a loaded certificate (:func:`nniquad.certificates.certificate.load_certificate`).

    ``horizon_s`` defaults to :data:`DEFAULT_HORIZON_S` for a certificate.  A
    :class:`StudySetup` is returned as it is (its own horizon and displacement
    radius; ``ranges`` is not applied again), with ``horizon_s`` replaced only
    when one is given.

    Gains, vehicle and inner-loop gains come from
    :func:`nniquad.certificates.certificate.certificate_gains`, ``certificate_vehicle`` and
    ``certificate_inner_loop``; the displacement radius from
    ``region_of_attraction.max_displacement_m`` (the nominal ``‖xi0_m‖`` when the
    certificate states no region), capped at ``ranges.max_displacement_m``;
    ``region_m`` replaces the certificate's region (e.g. the cascade's,
    :func:`within_certificate_ranges`), capped the same way; the settling band
    is then at most ``BAND_FRACTION`` (2 %) of that radius, so a run starting
    in a region narrower than the normal band must still be seen to converge.

    Raises
    ------
    MonteCarloError
        Bad horizon, or a certificate without a usable initial position.
    """
    if isinstance(cert, StudySetup):
        if horizon_s is None or horizon_s == cert.horizon_s:
            return cert
        h = positive_number_or_none(horizon_s)
        if h is None:
            raise MonteCarloError(f"horizon must be a positive number of seconds, got {horizon_s!r}")
        return replace(cert, horizon_s=h)
    roa = cert.get("region_of_attraction")
    tilt = positive_number_or_none(cert.get("tilt_limit_deg"))
    setup = study_setup_from(
        certificate_vehicle(cert), certificate_gains(cert), inner=certificate_inner_loop(cert),
        tilt_limit_deg=TILT_LIMIT_DEG if tilt is None else tilt, xi0_m=cert.get("xi0_m", XI0_M),
        region_m=region_m if region_m is not None else
        (roa.get("max_displacement_m") if isinstance(roa, Mapping) else None),
        ranges=ranges, horizon_s=DEFAULT_HORIZON_S if horizon_s is None else horizon_s,
        label=_certificate_label(cert),
    )
    if region_m is not None:
        # a region narrower than the normal band (2 % of the nominal start): a run must converge to 2 % of the
        # region's radius, or a start inside the band would count as settled at 0 s and prove nothing
        setup = replace(setup, band_m=min(setup.band_m, BAND_FRACTION * setup.region_m))
    return setup


def draw_scenarios(n: int, seed: int, ranges: ScenarioRanges = DEFAULT_RANGES,
                   cert: Mapping[str, Any] | StudySetup | None = None, *,
                   horizon_s: float | None = None) -> list[Scenario]:
    """Scenarios ``0`` to ``n - 1`` of seed ``seed`` of the study of ``cert``: a loaded certificate or a
    :class:`StudySetup` (:func:`nniquad.scenarios.draws.draw_scenarios` draws them from the setup).

    Parameters
    ----------
    n
        Number of scenarios.
    seed
        The study's seed.
    ranges
        What may vary.
    cert
        A loaded certificate (its setup is :func:`study_setup`) or a :class:`StudySetup`.
    horizon_s
        As in :func:`study_setup`: a setup keeps its own horizon unless one is given.

    Raises
    ------
    MonteCarloError
        ``n <= 0``, a negative or non-integer seed, no certificate.
    """
    if cert is None:
        raise MonteCarloError("a certificate (or a StudySetup) is required")
    return draw_setup_scenarios(n, seed, ranges, study_setup(cert, ranges, horizon_s=horizon_s))
