"""The region of attraction of the sampled cascade under the norm tilt limit.

:func:`linear_zone_reach` is the ellipsoid of the grid-checked ``P(θ)`` inside the zone where the limit is
inactive.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from nniquad.analysis.robust.box import ParameterBox, _coords
from nniquad.analysis.robust.family import CascadeFamily, _subsystem
from nniquad.analysis.robust.lyapunov import RobustLyapunov, _affine

__all__ = ["linear_zone_reach", "start_vector"]


def start_vector(fam: CascadeFamily, axis: str) -> np.ndarray:
    """The start state of an axis's subsystem per metre of displacement: the position 1, every other state 0 but
    the ``sni2`` law's controller state ``z``, at its DC value ``C(0)`` (:func:`nniquad.control.sni.start_state`)."""
    from nniquad.analysis.robust.family import subsystems
    from nniquad.control.gains import SNI2Gains
    from nniquad.control.sni import dc_gain

    names = subsystems(fam.state_names)[axis]
    v = np.zeros(len(names))
    v[0] = 1.0
    gains = fam.context["gains"] if isinstance(fam.context, Mapping) else None
    if isinstance(gains, SNI2Gains):
        v[names.index(f"zc_{axis}")] = dc_gain(gains.k, gains.omega)
    return v


def linear_zone_reach(lyap: Mapping[str, RobustLyapunov], dims, box: ParameterBox, fam: CascadeFamily,
                      L: float) -> float:
    """Smallest reach [m] over the points of ``fam`` of the linear-zone ellipsoid of the horizontal ``P(θ)``.

    At each point, with ``P = diag(P_x, P_y)``: the level ``c`` with
    ``sup_{xᵀPx <= c} ‖K x‖ = L`` is ``c = L² / max_a(K W_a Kᵀ)`` (``W_a = P_a⁻¹``);
    inside, the saturation is inactive and ``P`` contracts, so the set is invariant;
    a start ``r (cos α, sin α)`` has level ``r² (cos²α P_x00 + sin²α P_y00)``, so
    ``r = sqrt(c / max_a P_a00)``.  A law whose controller starts elsewhere than at 0 (``sni2``: at its DC
    value, :func:`start_vector`) has the start ``r v`` with level ``r² vᵀ P_a v`` in place of ``r² P_a00``.
    """
    kmax, pmax = None, None
    for a in ("x", "y"):
        _, _, _, K = _subsystem(fam, a)
        P = _affine(lyap[a].P, _coords(box, fam.points, dims[a]))
        W = np.linalg.inv(P)
        kw = (K @ W @ K.T)[..., 0, 0]
        v = start_vector(fam, a)
        level = np.einsum("i,nij,j->n", v, P, v)
        kmax = kw if kmax is None else np.maximum(kmax, kw)
        pmax = level if pmax is None else np.maximum(pmax, level)
    return float(np.min(np.sqrt(L * L / kmax / pmax)))
