"""The classes of certified designs of the NI structure: which theorem certifies a design.

``paper`` (the default)
    The paper's sector bound holds, ``γ = C(0)/(m kp) <= γ_max < 1`` (the NNI law:
    ``δ >= 1/(γ_max m kp)``)
    (``nniquad.config.GAMMA_MAX`` = 0.8, the paper's choice): Theorem
    ``thm:main_result`` of Ghallab & Petersen certifies the reduced horizontal
    loop, and a schema-2 certificate adds the sampled-data cascade section.
``cascade``
    The sector bound is dropped.  The proof is the sampled-data cascade
    certificate alone (:mod:`nniquad.analysis.cascade.box_certificate`: a
    parameter-dependent Lyapunov function of the linearised cascade sampled at
    the control rate over the parameter box, with its region of attraction
    under the tilt limit).  The reduced-loop LMIs are still stated (they hold
    whenever ``γ < 1``), but they are not what certifies the design.

Every filtered-derivative PD law is an NNI law with ``m kp δ > 1``
(:mod:`nniquad.laws.pd_filtered`): the ``cascade`` class holds all of
them, the ``paper`` class those with ``k_p τ_f/k_d >= 1/γ_max - 1``.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["LawClass", "LAW_CLASSES", "DEFAULT_LAW_CLASS", "law_class", "theorem_of", "SECTOR_RTOL",
           "within_sector_bound"]


@dataclass(frozen=True)
class LawClass:
    """A class of certified NNI designs.

    Attributes
    ----------
    name
        ``"paper"`` or ``"cascade"``.
    sector_bound
        Whether the class demands the paper's sector bound with ``γ_max``.
    needs_cascade
        Whether the class's proof is the sampled-data cascade section (a
        certificate of the class must have one).
    theorem
        The theorem that certifies a design of the class, as stated in a
        certificate (``law_class.theorem``) and printed by ``verify`` and ``report``.
    former_wordings
        Earlier wordings of the same theorem that signed certificates still state (``verify`` accepts them).
    """

    name: str
    sector_bound: bool
    needs_cascade: bool
    theorem: str
    former_wordings: tuple[str, ...] = ()

    def states_its_theorem(self, stated: object) -> bool:
        """Whether ``stated`` is this class's theorem, as worded now or as an earlier release worded it (a signed
        certificate keeps the words it was issued with; only the module path in them has moved).

        Parameters
        ----------
        stated
            The ``law_class.theorem`` text of a certificate.
        """
        return stated == self.theorem or stated in self.former_wordings


LAW_CLASSES: dict[str, LawClass] = {
    "paper": LawClass(
        "paper", sector_bound=True, needs_cascade=False,
        theorem="Theorem thm:main_result of Ghallab & Petersen: NNI plant, SNI controller and the sector bound "
                "delta >= 1/(gamma_max m kp) with gamma_max < 1 make the reduced horizontal loop asymptotically "
                "stable (with a cascade section, the sampled-data cascade certificate adds the parameter box)"),
    "cascade": LawClass(
        "cascade", sector_bound=False, needs_cascade=True,
        theorem="sampled-data cascade certificate (nniquad.analysis.cascade.box_certificate): a parameter-dependent Lyapunov "
                "function of the linearised cascade sampled at the control rate over the parameter box, with its "
                "region of attraction under the tilt limit; the paper's sector bound is not assumed",
        former_wordings=(
            "sampled-data cascade certificate (nniquad.analysis.robust_cascade): a parameter-dependent Lyapunov "
            "function of the linearised cascade sampled at the control rate over the parameter box, with its "
            "region of attraction under the tilt limit; the paper's sector bound is not assumed",)),
}

#: The class of a design unless stated otherwise (and of a certificate written before classes existed).
DEFAULT_LAW_CLASS = "paper"


def law_class(name: str) -> LawClass:
    """The :class:`LawClass` named ``name``, else ``ValueError`` naming the classes."""
    try:
        return LAW_CLASSES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown law class {name!r} (choose one of {', '.join(LAW_CLASSES)})") from None


def theorem_of(name: str) -> str:
    """The theorem that certifies a design of the class ``name``."""
    return law_class(name).theorem


#: Relative rounding allowance of the sector bound ``γ <= γ_max``.  The tuner's fastest designs sit on the
#: face ``γ = γ_max`` (``u = 0``), where ``γ`` recomputed from the stated gains lands an ulp or two either
#: side; the theorem itself needs only ``γ < 1``, which ``γ_max < 1`` keeps far away.
SECTOR_RTOL: float = 1e-12


def within_sector_bound(gamma: float, gamma_max: float) -> bool:
    """Whether ``γ <= γ_max`` holds, to the rounding allowance :data:`SECTOR_RTOL`.

    Parameters
    ----------
    gamma
        The design's sector (DC loop gain) constant.
    gamma_max
        The class's bound, in (0, 1).
    """
    return float(gamma) <= float(gamma_max) * (1.0 + SECTOR_RTOL)
