"""LMIs of the NI design: NI / SNI lemmas, closed-loop Lyapunov, robust and saturated versions.

Layout
------
:mod:`.solver`
    :class:`LMIResult`, data checks, Clarabel and cvxpy's status mapping.
:mod:`.checks`
    The numpy re-check functions (shared with :mod:`nniquad.certificates.verify`).
:mod:`.ni`
    NI / SNI lemmas on system matrices ``(A, B, C)`` (see its docstring for
    which lemma is which).
:mod:`.decay`
    Closed-loop and robust-mass decay rates of a :class:`~nniquad.analysis.reduced_loop.ReducedLoop`.
:mod:`.roa`
    Region of attraction under the tilt limit, and the certified reach.


Every function builds a cvxpy problem with symmetric matrix variables, solves it
with Clarabel (``solver=cp.CLARABEL``), checks ``problem.status`` against
cvxpy's status constants and then **re-checks the returned matrices with numpy**
(eigenvalues, residual norms) against the tolerance it reports.  The answer is
an :class:`LMIResult`.

* Infeasibility is a legitimate answer: ``feasible=False`` and ``status`` is the
  solver's status string (``'infeasible'``).
* A solver crash, an ``'unbounded'`` status or non-finite data raise
  :class:`nniquad.errors.SolverError`; nothing returns a silent ``None``.
* If the solver says ``'optimal'`` but the numpy re-check fails, the result is
  ``feasible=False`` with a note saying so; the solver's word alone never
  certifies anything.

"""

from __future__ import annotations

from nniquad.analysis.lmi import checks
from nniquad.analysis.lmi.checks import RTOL, ni_dissipation_matrix
from nniquad.analysis.lmi.decay import closed_loop_decay, robust_mass_decay
from nniquad.analysis.lmi.ni import (
    ni_dissipation_strict,
    ni_lemma_dissipation,
    ni_lemma_lanzon_petersen,
    ni_lemma_paper,
    sni_lemma,
)
from nniquad.analysis.lmi.reduced_region import (
    axis_acceleration_limit,
    certified_reach,
    certified_region,
    reach_of,
    region_of_attraction,
    start_certified,
)
from nniquad.analysis.lmi.solver import LMIResult
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.config import MASS_RANGE_FRACTION, TILT_LIMIT_DEG

__all__ = [
    "LMIResult",
    "RTOL",
    "checks",
    "ni_lemma_paper",
    "ni_lemma_dissipation",
    "ni_lemma_lanzon_petersen",
    "sni_lemma",
    "ni_dissipation_strict",
    "ni_dissipation_matrix",
    "closed_loop_decay",
    "robust_mass_decay",
    "axis_acceleration_limit",
    "region_of_attraction",
    "certified_region",
    "certified_reach",
    "reach_of",
    "start_certified",
    "run_all",
]



def run_all(loop: ReducedLoop, mass_range: tuple[float, float] | None = None,
            tilt_limit_deg: float = TILT_LIMIT_DEG) -> list[LMIResult]:
    """Every LMI of this package for one loop (vehicle mass, gravity and gains): what ``nniquad lmi`` prints.

    Plant LMIs are solved per distinct ``kp``, controller LMIs once, then the
    closed-loop decay, the robust-mass decay for both mass models of
    :func:`robust_mass_decay` (paper model, and thrust sized with the nominal
    mass) with one common P and with P(1/m), and the region of attraction of
    :func:`certified_region`.

    Parameters
    ----------
    loop
        The reduced loop (paper mass model).
    mass_range
        True-mass interval [kg] of the robust LMIs; default ``[0.8 m, 1.2 m]``.
    tilt_limit_deg
        Tilt limit [deg] of the region of attraction.
    """
    results: list[LMIResult] = []
    axes = loop.axes
    Ac, Bc, Cc, _ = loop.controller_matrices()
    for label, _ in axes:
        A, B, C, D = loop.plant_matrices(label)
        tag = "plant" if len(axes) == 1 else f"plant_{label}"
        results.append(ni_lemma_paper(A, B, C, name=f"ni_lemma_paper[{tag}]"))
        results.append(ni_lemma_dissipation(A, B, C, D, name=f"ni_lemma_dissipation[{tag}]"))
        results.append(ni_lemma_lanzon_petersen(A, B, C, D, name=f"ni_lemma_lanzon_petersen[{tag}]"))
        results.append(sni_lemma(A, B, C, D, name=f"sni_lemma[{tag}]"))
    results.append(ni_lemma_paper(Ac, Bc, Cc, name="ni_lemma_paper[controller]"))
    results.append(ni_lemma_dissipation(Ac, Bc, Cc, name="ni_lemma_dissipation[controller]"))
    results.append(ni_lemma_lanzon_petersen(Ac, Bc, Cc, name="ni_lemma_lanzon_petersen[controller]"))
    results.append(sni_lemma(Ac, Bc, Cc, name="sni_lemma[controller]"))
    results.append(ni_dissipation_strict(Ac, Bc, Cc, name="ni_dissipation_strict[controller]"))
    results.append(closed_loop_decay(loop))
    m = loop.m
    lo, hi = mass_range if mass_range is not None else (MASS_RANGE_FRACTION[0] * m, MASS_RANGE_FRACTION[1] * m)
    for thrust_model in (False, True):
        results.append(robust_mass_decay(loop, lo, hi, parameter_dependent=False, thrust_model=thrust_model))
        results.append(robust_mass_decay(loop, lo, hi, parameter_dependent=True, thrust_model=thrust_model))
    results += certified_region(loop, tilt_limit_deg)
    return results
