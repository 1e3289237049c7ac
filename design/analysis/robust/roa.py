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

__all__ = ["linear_zone_reach"]


def linear_zone_reach(lyap: Mapping[str, RobustLyapunov], dims, box: ParameterBox, fam: CascadeFamily,
                      L: float) -> float:
    """Smallest reach [m] over the points of ``fam`` of the linear-zone ellipsoid of the horizontal ``P(θ)``.

    At each point, with ``P = diag(P_x, P_y)``: the level ``c`` with
    ``sup_{xᵀPx <= c} ‖K x‖ = L`` is ``c = L² / max_a(K W_a Kᵀ)`` (``W_a = P_a⁻¹``);
    inside, the saturation is inactive and ``P`` contracts, so the set is invariant;
    a start ``r (cos α, sin α)`` has level ``r² (cos²α P_x00 + sin²α P_y00)``, so
    ``r = sqrt(c / max_a P_a00)``.
    """
    kmax, pmax = None, None
    for a in ("x", "y"):
        _, _, _, K = _subsystem(fam, a)
        P = _affine(lyap[a].P, _coords(box, fam.points, dims[a]))
        W = np.linalg.inv(P)
        kw = (K @ W @ K.T)[..., 0, 0]
        kmax = kw if kmax is None else np.maximum(kmax, kw)
        pmax = P[:, 0, 0] if pmax is None else np.maximum(pmax, P[:, 0, 0])
    return float(np.min(np.sqrt(L * L / kmax / pmax)))
