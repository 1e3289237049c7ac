"""The certificate's ``tracking`` section: the tracking-error bound of :mod:`nniquad.analysis.tracking_bound`, and its
re-check from the design alone (``verify``).

Layout (every number recomputed by ``verify``; units in the names)::

    class                {accel_limit_m_s2, jerk_limit_m_s3, start}
    bound_m              {no_feedforward, feedforward}     Euclidean bound on ‖ξ_h - ξ_h^d‖ over the class [m]
    per_axis_m           {no_feedforward, feedforward}     the same per axis [m]
    gains                the peak gains per unit of the class limits (TrackingBound.gains)
    euclidean_factor     1 (identical axes) or √2
    command_bound_m_s2   {no_feedforward, feedforward}     bound on the command's norm before the tilt limit
    zone_limit_m_s2      the tilt limit as a command norm (lowest mass covered)
    zone_holds           {no_feedforward, feedforward}     command bound <= zone limit
    zone_accel_limit_m_s2 {no_feedforward, feedforward}    the largest A for which the zone holds (at the stated J)
    rate_hz, controller, feedforward, covers, model, method, fine_steps
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from nniquad.analysis.cascade.box import ParameterBox
from nniquad.analysis.tracking_bound import METHOD, TrackingBound, tracking_bound
from nniquad.config import TRACKING_ACCEL_LIMIT_M_S2, TRACKING_JERK_LIMIT_M_S3
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CascadeError, InputError
from nniquad.laws.base import GainBlock
from nniquad.model.vehicle import Vehicle

__all__ = ["TRACKING_KEYS", "COVERS", "START", "MODEL", "TRACKING_RTOL", "tracking_section", "check_tracking_section",
           "section_of_bound"]

#: The keys of the section.
TRACKING_KEYS: frozenset[str] = frozenset((
    "class", "bound_m", "per_axis_m", "gains", "euclidean_factor", "command_bound_m_s2", "zone_limit_m_s2",
    "zone_holds", "zone_accel_limit_m_s2", "rate_hz", "controller", "feedforward", "covers", "model", "method", "fine_steps"))
#: What a section may cover: the nominal vehicle, or also the corners of the cascade section's box.
COVERS: tuple[str, ...] = ("nominal", "nominal and box corners")
#: The initial condition every bound assumes.
START = ("the run starts at a sample instant on the reference (position and velocity), level, rotors at hover, "
         "the law's state at rest")
#: The model the bound is of.
MODEL = ("the certificate's linearised sampled cascade at hover (attitude PD in its linear region, allocation, "
         "motor lag), position sampled and law run in discrete time at rate_hz, command held; feedforward: the "
         "reference's acceleration sampled with the position and held; valid while the command stays below the "
         "tilt limit (zone_holds)")
#: Relative agreement of a stated number with its recomputation (the computation is deterministic: only the
#: platform's floating point can move it).
TRACKING_RTOL = 1e-6
#: Entries compared on a scale other than their own size: ``dc_mismatch`` is ``|c - 1|``, a difference
#: from 1 that rounding alone makes (about 1e-13 at the nominal vehicle, other digits on another BLAS
#: kernel), so it is compared on the scale of 1.
TRACKING_SCALES: Mapping[str, float] = {"dc_mismatch": 1.0}


def section_of_bound(tb: TrackingBound, covers: str) -> dict[str, Any]:
    """The section's JSON of a computed :class:`~nniquad.analysis.tracking_bound.TrackingBound`."""
    return {
        "class": {"accel_limit_m_s2": tb.accel_limit_m_s2, "jerk_limit_m_s3": tb.jerk_limit_m_s3, "start": START},
        "bound_m": dict(tb.bound_m), "per_axis_m": dict(tb.per_axis_m), "gains": dict(tb.gains),
        "euclidean_factor": tb.euclidean_factor, "command_bound_m_s2": dict(tb.command_bound_m_s2),
        "zone_limit_m_s2": tb.zone_limit_m_s2, "zone_holds": dict(tb.zone_holds),
        "zone_accel_limit_m_s2": dict(tb.zone_accel_limit_m_s2), "rate_hz": tb.rate_hz,
        "controller": "discrete", "feedforward": "held", "covers": covers, "model": MODEL, "method": METHOD,
        "fine_steps": tb.fine_steps,
    }


def tracking_section(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, *, rate_hz: float,
                     tilt_limit_deg: float, box: ParameterBox | None = None,
                     accel_limit: float = TRACKING_ACCEL_LIMIT_M_S2,
                     jerk_limit: float = TRACKING_JERK_LIMIT_M_S3) -> dict[str, Any]:
    """The ``tracking`` section of a design (module docstring).

    Parameters
    ----------
    vehicle, gains, inner
        The certified design.
    rate_hz, tilt_limit_deg
        The cascade section's rate and the certificate's tilt limit.
    box
        The cascade section's box: its corners are covered too (about 20 s); ``None``: the nominal vehicle.
    accel_limit, jerk_limit
        The class [m/s², m/s³] (defaults :data:`nniquad.config.TRACKING_ACCEL_LIMIT_M_S2`,
        :data:`nniquad.config.TRACKING_JERK_LIMIT_M_S3`).
    """
    tb = tracking_bound(vehicle, gains, inner, rate_hz=rate_hz, tilt_limit_deg=tilt_limit_deg, box=box,
                        accel_limit=accel_limit, jerk_limit=jerk_limit)
    return section_of_bound(tb, COVERS[0] if box is None else COVERS[1])


def _same(stated: Any, computed: Any, path: str, bad: list[str]) -> None:
    if isinstance(computed, Mapping):
        if not isinstance(stated, Mapping) or set(stated) != set(computed):
            bad.append(f"{path} (keys)")
            return
        for k in computed:
            _same(stated[k], computed[k], f"{path}.{k}", bad)
    elif isinstance(computed, bool) or isinstance(computed, str) or isinstance(computed, int):
        if type(stated) is not type(computed) or stated != computed:
            bad.append(path)
    else:
        ok = (isinstance(stated, (int, float)) and not isinstance(stated, bool) and math.isfinite(stated)
              and abs(float(stated) - computed)
              <= TRACKING_RTOL * max(abs(computed), TRACKING_SCALES.get(path.rsplit(".", 1)[-1], 1e-12)))
        if not ok:
            bad.append(f"{path} (stated {stated!r}, recomputed {computed:.9g})")


def check_tracking_section(section: Mapping[str, Any], vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, *,
                           rate_hz: float, tilt_limit_deg: float, box: ParameterBox | None) -> tuple[bool, str]:
    """Recompute a stated ``tracking`` section from the design and compare every entry.

    The stated class limits and coverage are the inputs; everything else must equal the recomputation (numbers
    within :data:`TRACKING_RTOL`, texts and flags exactly).

    Parameters
    ----------
    section
        The stated section.
    vehicle, gains, inner
        The certified design.
    rate_hz, tilt_limit_deg
        The cascade section's rate and the certificate's tilt limit (the section must state the same rate).
    box
        The cascade section's box (used when the section covers its corners).

    Returns
    -------
    ok, detail
        Whether every entry is reproduced, and one line: the figures, or what differs.
    """
    if not isinstance(section, Mapping) or set(section) != TRACKING_KEYS:
        got = sorted(section) if isinstance(section, Mapping) else type(section).__name__
        return False, f"the section must have exactly the keys {', '.join(sorted(TRACKING_KEYS))}; got {got}"
    cls = section["class"]
    covers = section["covers"]
    if not isinstance(cls, Mapping) or covers not in COVERS:
        return False, f"class must be an object and covers one of {COVERS}"
    if covers == COVERS[1] and box is None:
        return False, "the section covers box corners, and the certificate has no box"
    try:
        computed = tracking_section(vehicle, gains, inner, rate_hz=rate_hz, tilt_limit_deg=tilt_limit_deg,
                                    box=box if covers == COVERS[1] else None,
                                    accel_limit=cls.get("accel_limit_m_s2"), jerk_limit=cls.get("jerk_limit_m_s3"))
    except (CascadeError, InputError) as exc:
        return False, f"not recomputed: {exc}"
    bad: list[str] = []
    _same(section, computed, "tracking", bad)
    if bad:
        return False, "differs from the recomputation: " + "; ".join(bad[:4]) + (" ..." if len(bad) > 4 else "")
    b, c = computed["bound_m"], computed["command_bound_m_s2"]
    A, J = computed["class"]["accel_limit_m_s2"], computed["class"]["jerk_limit_m_s3"]
    zone, za = computed["zone_holds"], computed["zone_accel_limit_m_s2"]

    def zone_text(case: str) -> str:
        return (f"command <= {c[case]:.3g} m/s², linear zone {'holds' if zone[case] else 'NOT certified'} for the "
                f"class, holds for |a_d| <= {za[case]:.3g} m/s²")

    return True, (f"|a_d| <= {A:g} m/s²: |e| <= {b['no_feedforward']:.4g} m without feedforward "
                  f"({zone_text('no_feedforward')}); with |jerk| <= {J:g} m/s³ and held feedforward |e| <= "
                  f"{b['feedforward']:.4g} m ({zone_text('feedforward')}); tilt limit "
                  f"{computed['zone_limit_m_s2']:.3g} m/s², {covers}, {rate_hz:g} Hz")
