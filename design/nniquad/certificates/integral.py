"""What a certificate of a law with integral action states in place of the paper's reduced-loop sections.

A law with integral action (:mod:`nniquad.laws.integral`, ``nni_i`` and ``sni2_i``) is outside Theorem
``thm:main_result`` of Ghallab & Petersen: its controller's DC gain ``C(0)`` is infinite (no sector bound holds)
and ``-m̂ k_i/s`` is not negative imaginary (the controller's NI lemma fails).  Its certificate therefore claims
nothing of the paper's reduced loop: the sections ``sector``, ``stability_margin``, ``lmi`` and
``region_of_attraction`` each hold only ``{"not_applicable": reason}`` (:func:`reduced_loop_sections`), and the
``start`` section names the cascade's region alone.  The design is certified by the sampled-data cascade section
(class ``cascade``): the integrator and its anti-windup are part of the sampled loop it analyses
(:func:`nniquad.analysis.cascade.family.anti_windup_rows`), over the parameter box, at the control rate, with its
Lur'e region through the saturation.  ``law_class.integral_action`` says so in words
(:func:`integral_action_block`); ``verify`` compares every one of these texts with the library's and rejects a
certificate of an NI law that states them, or of an integral law that states anything else.
"""

from __future__ import annotations

from typing import Any, Mapping

from nniquad.certificates.check_record import Check, thaw_json
from nniquad.laws.base import ControlLaw

__all__ = ["NOT_APPLICABLE", "REDUCED_LOOP_SECTIONS", "ANTI_WINDUP", "CASCADE_COVERS", "states_reduced_loop",
           "not_applicable_reason", "reduced_loop_sections", "integral_action_block", "reduced_loop_check"]

#: The key of a section that the certified law's theorem does not provide.
NOT_APPLICABLE = "not_applicable"
#: The sections of the paper's reduced loop (Theorem thm:main_result and its LMIs).
REDUCED_LOOP_SECTIONS: tuple[str, ...] = ("sector", "stability_margin", "lmi", "region_of_attraction")
#: The anti-windup of the integral laws, as a certificate states it.
ANTI_WINDUP = ("back-calculation with tracking time T_t = ks/ki, ks = kp - C(0)/m = kp (1 - gamma) the base law's "
               "static stiffness per unit mass: q' = xi + (a - sat(a))/ks per axis, a - sat(a) the excess of the total "
               "command over the norm tilt limit; certified discrete law q[k+1] = q[k] + T (xi[k] + (a[k] - "
               "sat(a[k]))/ks), linear in the dead zone, so the cascade's sampled loop x+ = A0 x + B sat(K x) holds it "
               "exactly (A0 + E K, B = Gamma - E, E = T/ks on the integrator rows: cascade.matrices.E_anti_windup)")
#: What the cascade section certifies of an integral law.
CASCADE_COVERS = ("the sampled-data cascade section: exponential stability of the linearised cascade sampled at the "
                  "control rate over the parameter box, the integrator included, and its Lur'e region of attraction "
                  "through the tilt saturation with the anti-windup in the loop, for the start stated in "
                  "cascade.region_of_attraction.note")


def states_reduced_loop(law: ControlLaw) -> bool:
    """Whether a certificate of ``law`` states the paper's reduced-loop sections (a law of the NI structure).

    Parameters
    ----------
    law
        The certified law.
    """
    return bool(law.ni_structure)


def not_applicable_reason(law: ControlLaw) -> str:
    """Why the reduced-loop sections are not stated for ``law`` (one sentence).

    Parameters
    ----------
    law
        The certified law (one with integral action).
    """
    return (f"not applicable to the {law.name} law (integral action): its C(0) is infinite and -m k_i/s is not "
            "negative imaginary, so Theorem thm:main_result of Ghallab & Petersen (NI plant, SNI controller, sector "
            "bound) does not certify it and its reduced-loop sector, NI and region LMIs are not claimed; the "
            "sampled-data cascade section certifies the design")


def reduced_loop_sections(law: ControlLaw) -> dict[str, dict[str, str]]:
    """The four reduced-loop sections of a certificate of ``law`` that has no such theorem.

    Parameters
    ----------
    law
        The certified law.
    """
    reason = not_applicable_reason(law)
    return {k: {NOT_APPLICABLE: reason} for k in REDUCED_LOOP_SECTIONS}


def integral_action_block(law: ControlLaw) -> dict[str, str]:
    """``law_class.integral_action``: the integral gain's name, the anti-windup, the start, and which theorem
    certifies what.

    Parameters
    ----------
    law
        The certified law (one with integral action).
    """
    return {"integral_gain": "ki [1/s^3] (gains.ki): a_h = -kp xi + z/m - ki q, q' = xi",
            "anti_windup": ANTI_WINDUP, "start": law.start_description,
            "not_certified_by": not_applicable_reason(law), "certified_by": CASCADE_COVERS}


def reduced_loop_check(cert: Any) -> Check:
    """``verify``'s check of a certificate of a law without the paper's theorem: the reduced-loop sections and
    ``law_class.integral_action`` are exactly the library's texts for the law (nothing more is claimed).

    Parameters
    ----------
    cert
        A :class:`nniquad.certificates.certificate.Certificate`.
    """
    law = cert.gains.law
    want = reduced_loop_sections(law)
    bad = [k for k in REDUCED_LOOP_SECTIONS if thaw_json(getattr(cert, k)) != want[k]]
    block = cert.law_class.get("integral_action") if isinstance(cert.law_class, Mapping) else None
    if thaw_json(block) != integral_action_block(law):
        bad.append("law_class.integral_action")
    return Check("reduced loop not applicable", not bad,
                 f"the {law.name} law is certified by the cascade section alone; the reduced-loop sections state "
                 "only why they do not apply" if not bad else f"not the library's statement: {', '.join(bad)}")
