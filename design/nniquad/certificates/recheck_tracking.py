"""``verify``'s re-check of the ``tracking`` section: the tracking-error bound recomputed from the design alone."""

from __future__ import annotations

from nniquad.analysis.cascade.box import ParameterBox
from nniquad.analysis.tracking_section import COVERS, check_tracking_section
from nniquad.certificates.certificate import Certificate
from nniquad.certificates.check_record import Check, gains_key, memo, thaw_json
from nniquad.errors import NniquadError

__all__ = ["tracking_check", "NOT_STATED"]

#: The note of a certificate without the section (written before it existed): not a failure, not a claim.
NOT_STATED = "tracking: not stated (no tracking-error bound is certified by this certificate)"


def tracking_check(cert: Certificate) -> Check:
    """Recompute the stated ``tracking`` section (:func:`nniquad.analysis.tracking_section.check_tracking_section`)
    at the cascade section's rate and, when it covers them, its box's corners.

    Parameters
    ----------
    cert
        A certificate with a ``tracking`` section.
    """
    if cert.cascade is None:
        return Check("tracking", False, "a tracking section needs the cascade section (its rate and box)")
    section = thaw_json(cert.tracking)
    # the box is an input only when the section covers its corners (an edit of it then re-runs nothing else)
    corners = isinstance(section, dict) and section.get("covers") == COVERS[1]
    try:
        rate = float(cert.cascade["rate_hz"])
        box = ParameterBox.from_json(cert.cascade["box"]) if corners else None
    except (KeyError, TypeError, ValueError, NniquadError) as exc:
        return Check("tracking", False, f"the cascade section's rate or box is unreadable ({exc})")
    # a pure function of the section and the design: an edit elsewhere in the document does not re-run it
    ok, detail = memo("tracking", [section, cert.vehicle.as_dict(), gains_key(cert), cert.inner_loop.as_dict(),
                                   rate, cert.tilt_limit_deg, box.to_json() if box is not None else None],
                      lambda: check_tracking_section(section, cert.vehicle, cert.gains, cert.inner_loop,
                                                     rate_hz=rate, tilt_limit_deg=cert.tilt_limit_deg, box=box))
    return Check("tracking", ok, detail)
