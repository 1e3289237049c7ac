"""The region of attraction of the sampled cascade under the norm tilt limit: what a region certifies, with numpy.

The loop
--------
At a parameter point θ the horizontal command ``a = K x`` (both axes) is limited in norm by the tilt limit,
``sat_L(a) = a min(1, L/‖a‖)`` with ``L(θ) = f_m g tan(tilt)`` (``g_z = (m/m̂) g`` at hover; its lowest value
over the box is ``u0``).  In the normalised command ``ν = K x / L`` the sampled loop is
``x⁺ = A_d x - B L ψ(ν)`` with the dead zone ``ψ(ν) = ν - sat(ν)`` of the unit ball (:mod:`nniquad.analysis.cascade.family`).

Two regions
-----------
* :func:`linear_zone_reach`: the ellipsoid of the grid-checked ``P(θ)`` inside ``‖K x‖ <= u0``, where the limit is
  inactive.  It cannot reach beyond about ``u0 / kp``.
* The **Lur'e-Postnikov** region (:class:`LureRegion`), which reaches deep into the saturation:
  ``V_θ(x) = Σ_a x_aᵀ P_a(θ) x_a + 2 μ(θ) Φ(ν)``, ``a ∈ {x, y}``, with ``Φ(ν) = ‖ν‖²/2`` for ``‖ν‖ <= 1`` and
  ``‖ν‖ - 1/2`` outside (the Huber function: convex, its gradient is ``sat``, 1-Lipschitz).  The region is
  ``{V_θ <= c}``.  Along the loop,

  - ``Φ(ν⁺) - Φ(ν) <= sat(ν⁺)ᵀ(ν⁺ - ν) - ‖sat(ν⁺) - sat(ν)‖²/2`` (convexity and 1-smoothness of ``Φ``;
    Nesterov, *Introductory Lectures on Convex Optimization*, 2004, Thm 2.1.5);
  - ``ψᵀ(ψ - Ĝ x) <= 0`` wherever ``‖(K̂ - Ĝ) x‖ <= 1``, ``K̂ = K/L`` (the generalised sector condition of
    Gomes da Silva & Tarbouriech, IEEE TAC 50(1), 2005, in vector form: ``ψ`` is parallel to ``ν``, so
    ``ψᵀ(ν - Ĝx) <= ‖ψ‖ ‖(K̂ - Ĝ)x‖ <= ‖ψ‖ = ψᵀ sat(ν)``);

  so ``V(x⁺) - V(x) + (1 - ρ²) xᵀPx <= ξᵀ F ξ`` with ``ξ = (x, ψ(ν), ψ(ν⁺))`` and ``F`` the quadratic form of
  :func:`decrease_forms`.  ``F ≺ 0`` for each axis at a point proves the decrease there: every term is a sum
  over the two axes with **scalar** ``μ`` and sector multiplier (fixed to 1: ``V`` is scaled freely), and
  ``P``, ``Ĝ`` are block-diagonal, so although the norm limit couples the axes the 2-D form is the sum of the
  axis forms.  The inclusion ``c (K̂_a - Ĝ_a) P_a⁻¹ (K̂_a - Ĝ_a)ᵀ <= 1`` for both axes puts ``{xᵀPx <= c}``,
  hence ``{V <= c}`` (``μ >= 0``), inside the sector zone, so the region is invariant and every start in it
  converges.  ``P_a, Ĝ_a`` are quadratic in the axis's box coordinates and ``μ`` in the coordinates shared by
  both axes (:func:`features`): ``V`` depends on the (constant) parameters only.

The reach is the largest ``r`` with every start ``r (cos α, sin α)`` at rest inside, each axis's controller
at the law's take-over state for its position (:func:`start_vector` ``v_a``: the position 1, the controller's
start per metre; ``v_a = e_0`` for a law that starts at 0):
``r² max_a v_aᵀP_a v_a + 2 μ Φ(r k_s / L) <= c``, ``k_s = max_a |K_a v_a|`` the larger command per metre of
the start (``Φ`` grows with the norm, and the start's command is ``r (cos α K_x v_x, sin α K_y v_y)``).  The
loop enters only through ``A_d``, ``B`` and ``K``: with the anti-windup of an integral law ``B`` has controller
rows (:func:`nniquad.analysis.cascade.family.sampled_family`), and nothing here changes.  The LMI is in
:mod:`nniquad.analysis.cascade.region_lmi`; everything here is numpy, for ``certify`` and ``verify`` alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from nniquad.analysis.cascade.box import POINT_NAMES, ParameterBox, normalised_coordinates
from nniquad.analysis.cascade.family import (
    SUBSYSTEMS,
    CascadeFamily,
    mode_transform,
    subsystem_blocks,
    subsystem_of,
    subsystems,
)
from nniquad.analysis.cascade.lyapunov import RobustLyapunov, affine_in, spectral_norms
from nniquad.analysis.lmi import checks as lmi_checks
from nniquad.laws.base import ControlLaw
from nniquad.sim import delay_state_names

__all__ = ["linear_zone_reach", "HORIZONTAL", "features", "LureRegion", "decrease_forms", "LureCheck",
           "lure_check", "coupled_decrease", "coupled_parts", "huber", "lure_block", "check_lure_block", "ROA_NOTE", "roa_note",
           "start_vector", "start_command", "axis_states"]

#: The horizontal subsystems, whose command the tilt limit bounds.
HORIZONTAL: tuple[str, str] = ("x", "y")
#: What ``region_of_attraction.note`` of a certificate says (compared by ``verify``).
ROA_NOTE = ("lure: the region {V <= c} of V = x'P(θ)x + 2 μ(θ) Φ(K x / L(θ)) (Lur'e-Postnikov; Φ the Huber "
            "function of the normalised command, whose gradient is the norm saturation), L(θ) = (mass factor) g "
            "tan(tilt) >= u0; decrease from the convexity and 1-smoothness of Φ and the generalised sector "
            "condition, for each axis at the LMI points and the grid and on the coupled 19-state loop at the grid; "
            "linear_zone: the level set x'P(θ)x <= c(θ) of the grid-checked Lyapunov matrix inside ‖K x‖ <= u0 "
            "(no saturation inside). u0 = (min mass factor) g tan(tilt); start: position offset in any "
            "direction, all else at hover, controller state 0")
#: The form of the stated Lur'e-Postnikov region (compared by ``verify``).
LURE_FORM = ("P_a(θ) = Σ_f φ_f(θ_a) P_a,f, G_a(θ) likewise, μ(θ) = Σ_f φ_f(θ_m) μ_f; φ = 1, θ_j, θ_j θ_k (j < k), "
             "θ_j² of the axis's log factors normalised on the box (θ_m: those of both axes); the sector "
             "multiplier is 1; V(x⁺) - V(x) <= -(1 - rho²) x'Px")
def roa_note(law: ControlLaw, delay_samples: int = 0) -> str:
    """The stated region-of-attraction note: :data:`ROA_NOTE` with the law's start
    (:attr:`~nniquad.laws.base.ControlLaw.start_description`; :func:`start_vector`) and the coupled loop's size.

    Parameters
    ----------
    law
        The certified law.
    delay_samples
        The measurement delay line's length: it starts full of the start position.
    """
    n = 17 + len(law.sim_state_names) + 2 * int(delay_samples)
    start = law.start_description + (f", the measurement delay line ({int(delay_samples)} samples) full of the start "
                                      "position" if delay_samples else "")
    return ROA_NOTE.replace("controller state 0", start).replace("19-state", f"{n}-state")


def start_vector(fam: CascadeFamily, axis: str) -> np.ndarray:
    """The start state of an axis's subsystem per metre of displacement: the position 1, the law's controller
    states at their take-over values (:meth:`nniquad.laws.base.ControlLaw.start_map`), the measurement delay
    line (if any) 1 too (the vehicle sat at the start before take-over), every other state 0.

    Parameters
    ----------
    fam
        The sampled family (its context holds the gains and the vehicle).
    axis
        ``"x"`` or ``"y"``.
    """
    names = subsystems(fam.state_names)[axis]
    v = np.zeros(len(names))
    v[0] = 1.0
    ctx = fam.context if isinstance(fam.context, Mapping) else {}
    gains, vehicle = ctx.get("gains"), ctx.get("vehicle")
    if gains is not None:
        law = gains.law
        a = HORIZONTAL.index(axis)
        S = law.start_map(gains, vehicle.m if vehicle is not None else 1.0)
        for i, name in enumerate(law.sim_state_names):
            if name.endswith(f"_{axis}") and name in names:
                v[names.index(name)] = S[i, a]
    for name in delay_state_names(fam.delay_samples):
        if name.endswith(f"_{axis}"):
            v[names.index(name)] = 1.0
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
    for a in HORIZONTAL:
        _, _, _, K = subsystem_of(fam, a)
        P = affine_in(lyap[a].P, normalised_coordinates(box, fam.points, dims[a]))
        W = np.linalg.inv(P)
        kw = (K @ W @ K.T)[..., 0, 0]
        v = start_vector(fam, a)
        level = np.einsum("i,nij,j->n", v, P, v)
        kmax = kw if kmax is None else np.maximum(kmax, kw)
        pmax = level if pmax is None else np.maximum(pmax, level)
    return float(np.min(np.sqrt(L * L / kmax / pmax)))


def axis_states(fam: CascadeFamily) -> dict[str, int]:
    """Each horizontal axis's number of states in ``fam`` (the law's controller states included)."""
    return {a: len(subsystems(fam.state_names)[a]) for a in HORIZONTAL}


def features(theta: np.ndarray) -> np.ndarray:
    """The basis of a quadratic function of ``θ ∈ [-1, 1]^q``: ``1, θ_j, θ_j θ_k (j < k), θ_j²`` (``(N, nf)``)."""
    th = np.atleast_2d(np.asarray(theta, float))
    q = th.shape[1]
    cols = [np.ones(th.shape[0])] + [th[:, j] for j in range(q)]
    cols += [th[:, j] * th[:, k] for j in range(q) for k in range(j + 1, q)] + [th[:, j] ** 2 for j in range(q)]
    return np.stack(cols, axis=1)


def n_features(q: int) -> int:
    """Number of :func:`features` of ``q`` coordinates."""
    return 1 + 2 * q + q * (q - 1) // 2


def huber(s: np.ndarray) -> np.ndarray:
    """``Φ`` of a command of norm ``s`` (units of the limit): ``s²/2`` up to 1, ``s - 1/2`` beyond."""
    s = np.abs(np.asarray(s, float))
    return np.where(s <= 1.0, 0.5 * s * s, s - 0.5)


@dataclass(frozen=True)
class LureRegion:
    """A Lur'e-Postnikov region of attraction of the horizontal axes (module docstring).

    Attributes
    ----------
    P : dict of ndarray (nf_a, n, n)
        Each axis's ``P_a(θ) = Σ_f φ_f(θ) P_a,f`` (:func:`features` of the axis's coordinates ``dims[a]``).
    G : dict of ndarray (nf_a, 1, n)
        Each axis's sector matrix ``Ĝ_a(θ)`` (normalised command units), same basis.
    mu : ndarray (nf_m,)
        ``μ(θ)`` in the basis of the shared coordinates ``mult_dims``.
    level
        ``c``: the region is ``{V_θ <= c}``.
    rho
        ``V(x⁺) - V(x) <= -(1 - ρ²) xᵀPx``: the decrease per sample.
    dims : dict
        Each axis's point coordinates (indices of :data:`POINT_NAMES`).
    mult_dims
        The coordinates of ``μ`` (those of both axes).
    """

    P: Mapping[str, np.ndarray]
    G: Mapping[str, np.ndarray]
    mu: np.ndarray
    level: float
    rho: float
    dims: Mapping[str, tuple[int, ...]]
    mult_dims: tuple[int, ...]

    def at(self, box: ParameterBox, points: np.ndarray, axis: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``P_a(θ), Ĝ_a(θ), μ(θ)`` at ``points`` (``(N, 6)`` factors)."""
        fa = features(normalised_coordinates(box, points, self.dims[axis]))
        fm = features(normalised_coordinates(box, points, self.mult_dims))
        return (np.einsum("nf,fij->nij", fa, self.P[axis]), np.einsum("nf,fij->nij", fa, self.G[axis]),
                fm @ np.asarray(self.mu, float))

    def to_json(self) -> dict[str, Any]:
        return {"level": self.level, "rho": self.rho, "mult_dims": [POINT_NAMES[j] for j in self.mult_dims],
                "P": {a: np.asarray(self.P[a]).tolist() for a in HORIZONTAL},
                "G": {a: np.asarray(self.G[a]).tolist() for a in HORIZONTAL},
                "mu": np.asarray(self.mu).tolist()}

    @classmethod
    def from_json(cls, data: Mapping[str, Any], dims: Mapping[str, Sequence[int]],
                  n_states: Mapping[str, int] | None = None) -> "LureRegion":
        """Read a stated region (``dims``: the axes' coordinates stated by the Lyapunov block; ``n_states``: each
        axis's states, default those of :data:`~nniquad.analysis.cascade.family.SUBSYSTEMS`, more with a delay line).

        Raises
        ------
        ValueError
            A shape that does not fit the coordinates, a non-symmetric ``P``, a non-finite number.
        """
        mult = tuple(POINT_NAMES.index(n) for n in data["mult_dims"])
        P = {a: np.asarray(data["P"][a], float) for a in HORIZONTAL}
        G = {a: np.asarray(data["G"][a], float) for a in HORIZONTAL}
        mu = np.asarray(data["mu"], float)
        for a in HORIZONTAL:
            nf, n = n_features(len(dims[a])), (len(SUBSYSTEMS[a]) if n_states is None else int(n_states[a]))
            if P[a].shape != (nf, n, n) or G[a].shape != (nf, 1, n):
                raise ValueError(f"axis {a}: P or G does not have the shape of {nf} features of {n} states")
            if not np.array_equal(P[a], np.swapaxes(P[a], -1, -2)):
                raise ValueError(f"axis {a}: P is not symmetric")
        if mu.shape != (n_features(len(mult)),) or not set(mult) <= set(dims["x"]) & set(dims["y"]):
            raise ValueError("mu does not fit its coordinates, or they are not shared by both axes")
        level, rho = float(data["level"]), float(data["rho"])
        if not all(np.all(np.isfinite(v)) for v in (*P.values(), *G.values(), mu, level, rho)):
            raise ValueError("a number of the region is not finite")
        return cls(P=P, G=G, mu=mu, level=level, rho=rho, dims={a: tuple(dims[a]) for a in HORIZONTAL},
                   mult_dims=mult)


def _selectors(n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows picking ``x``, ``ψ`` and ``ψ⁺`` out of ``ξ = (x, ψ, ψ⁺)`` (``m`` inputs)."""
    eye = np.eye(n + 2 * m)
    return eye[:n], eye[n:n + m], eye[n + m:]


def _sy(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.swapaxes(a, -1, -2) @ b + np.swapaxes(b, -1, -2) @ a


def next_state_rows(A: np.ndarray, Bh: np.ndarray) -> np.ndarray:
    """``x⁺ = A x - Bh ψ`` as rows of ``ξ = (x, ψ, ψ⁺)``: ``[A, -Bh, 0]``, ``(N, n, n + 2m)``."""
    return np.concatenate([A, -Bh, np.zeros(Bh.shape)], axis=-1)


def form_parts(A: np.ndarray, Bh: np.ndarray, Kh: np.ndarray) -> dict[str, np.ndarray]:
    """The parts of :func:`decrease_forms` that do not depend on ``P, Ĝ, μ`` (stacks over points).

    ``A (N, n, n)`` the linear loop, ``Bh = B L (N, n, m)``, ``Kh = K / L (N, m, n)``.  Returns ``X``, ``Xp``
    (``x`` and ``x⁺`` as rows of ``ξ``), ``ps``, ``Mmu`` (the Lur'e term per unit ``μ``) and ``Fc`` (the sector
    term's ``-2 ψᵀψ``).
    """
    n, m = A.shape[-1], Bh.shape[-1]
    X, ps, pp = _selectors(n, m)
    Xp = next_state_rows(A, Bh)
    v, vp = Kh @ X, Kh @ Xp
    s = (vp - pp) - (v - ps)  # sat(ν⁺) - sat(ν)
    Mmu = _sy(vp - pp, vp - v) - np.swapaxes(s, -1, -2) @ s
    return {"X": X, "Xp": Xp, "ps": ps, "Mmu": Mmu, "Fc": np.broadcast_to(-2.0 * ps.T @ ps, Mmu.shape)}


def decrease_forms(A: np.ndarray, Bh: np.ndarray, Kh: np.ndarray, P: np.ndarray, G: np.ndarray, mu: np.ndarray,
                   rho: float, absolute: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``F`` (module docstring) at every point, and the same expression formed from absolute values.

    ``F = x⁺ᵀPx⁺ - ρ² xᵀPx + μ [2 sat(ν⁺)ᵀ(ν⁺ - ν) - ‖sat(ν⁺) - sat(ν)‖²] - 2 ψᵀ(ψ - Ĝ x)`` as a form in
    ``ξ = (x, ψ, ψ⁺)``; ``P (N, n, n)``, ``G (N, m, n)``, ``mu (N,)``.  The second array bounds the float64
    error of every entry of the first (:func:`nniquad.analysis.lmi.checks.scaled_eig_margin`); ``absolute``
    gives entrywise bounds of ``|A|, |Bh|, |Kh|`` when the data are themselves products (default: their
    absolute values).
    """
    parts = form_parts(A, Bh, Kh)
    X, Xp, ps = parts["X"], parts["Xp"], parts["ps"]
    n, m = X.shape[0], ps.shape[0]
    mu = np.asarray(mu, float)[:, None, None]
    # X and ψ are coordinate selectors: xᵀPx and the ψᵀĜx terms are P and Ĝ written into their blocks of ξ
    # (the same numbers as the products with the 0/1 selectors, which only add exact zeros)
    F = np.swapaxes(Xp, -1, -2) @ P @ Xp + mu * parts["Mmu"] + parts["Fc"]
    F[:, :n, :n] -= rho * rho * P
    F[:, n:n + m, :n] += G
    F[:, :n, n:n + m] += np.swapaxes(G, -1, -2)
    aA, aB, aK = absolute if absolute is not None else (np.abs(A), np.abs(Bh), np.abs(Kh))
    absP = np.abs(P)
    aXp = np.abs(next_state_rows(aA, aB))
    v_abs = aK @ X
    vp_abs = aK @ aXp
    pp = np.eye(X.shape[1])[n + m:]
    s_abs = vp_abs + pp + v_abs + ps
    mu_abs = _sy(vp_abs + pp, vp_abs + v_abs) + np.swapaxes(s_abs, -1, -2) @ s_abs
    F_abs = np.swapaxes(aXp, -1, -2) @ absP @ aXp + np.abs(mu) * mu_abs + np.abs(parts["Fc"])
    F_abs[:, :n, :n] += rho * rho * absP
    absG = np.abs(G)
    F_abs[:, n:n + m, :n] += absG
    F_abs[:, :n, n:n + m] += np.swapaxes(absG, -1, -2)
    return 0.5 * (F + np.swapaxes(F, -1, -2)), F_abs


def scaled_eig_margins(M: np.ndarray, M_abs: np.ndarray, n_inner: int,
                       scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(λ_max(S M S), bound)`` per matrix of a stack, ``S = diag(scale)^{-1/2}``: a strict ``M ≺ 0`` is certified
    iff the first is below minus the second.

    As :func:`nniquad.analysis.lmi.checks.scaled_eig_margin`, but the diagonal congruence is given: the decrease
    form is judged against ``diag(P) ⊕ I`` (each state in the units of ``V``, each dead-zone input in those of the
    limit), the same metric in which the LMI demands its margin (:mod:`nniquad.analysis.cascade.region_lmi`).
    ``bound = ROUNDING_SAFETY EPS (n_inner ‖S |M_abs| S‖₂ + dim max|λ|)``.
    """
    d = 1.0 / np.sqrt(np.asarray(scale, float))
    Ms = M * d[..., :, None] * d[..., None, :]
    Es = np.abs(M_abs) * d[..., :, None] * d[..., None, :]
    finite = np.all(np.isfinite(Ms), axis=(-2, -1)) & np.all(np.isfinite(Es), axis=(-2, -1))
    ev = np.linalg.eigvalsh(np.where(finite[..., None, None], Ms, 0.0))
    bound = lmi_checks.ROUNDING_SAFETY * lmi_checks.EPS * (
        int(n_inner) * spectral_norms(np.where(finite[..., None, None], Es, 0.0))
        + M.shape[-1] * np.max(np.abs(ev), axis=-1))
    # a non-positive diagonal of P (no metric, and P not positive definite) is a failure, never a margin
    return np.where(finite, ev[..., -1], np.inf), bound


def margin_scale(P: np.ndarray, m: int) -> np.ndarray:
    """The diagonal ``diag(P) ⊕ 1_{2m}`` of the decrease's metric (:func:`scaled_eig_margins`), ``(N, n + 2m)``."""
    diag = np.diagonal(P, axis1=-2, axis2=-1)
    return np.concatenate([np.where(diag > 0, diag, np.nan), np.ones(diag.shape[:-1] + (2 * m,))], axis=-1)


def axis_loops(fam: CascadeFamily, axis: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A_d, B L, K / L)`` of a horizontal axis at every point of ``fam`` (unit saturation of ``ν``)."""
    A, _, B, K = subsystem_of(fam, axis)
    L = np.broadcast_to(np.asarray(fam.accel_limit, float), (A.shape[0],))
    return A, B * L[:, None, None], K[None] / L[:, None, None]


def start_command(fam: CascadeFamily) -> float:
    """``k_s = max_a |K_a v_a|``: the larger command per metre of the start (:func:`start_vector`) [1/s²]."""
    return max(abs(float((subsystem_of(fam, a)[3] @ start_vector(fam, a))[0])) for a in HORIZONTAL)


def reach_at(p00: np.ndarray, mu: np.ndarray, level: float, L: np.ndarray, k_max: float) -> np.ndarray:
    """Largest ``r`` with ``r² p00 + 2 μ Φ(r k_max / L) <= c`` at every point (closed form; ``p00 > 0``): ``p00``
    the start's level per square metre, ``k_max`` its command per metre."""
    p00, mu, L = (np.asarray(v, float) for v in (p00, mu, L))
    r_in = np.sqrt(level / (p00 + mu * k_max * k_max / (L * L)))  # the start's command inside the unit ball
    b = 2.0 * mu * k_max / L
    r_out = (-b + np.sqrt(b * b + 4.0 * p00 * (level + mu))) / (2.0 * p00)  # p00 r² + b r - (c + μ) = 0
    return np.where(r_in * k_max <= L, r_in, r_out)


@dataclass(frozen=True)
class LureCheck:
    """What a :class:`LureRegion` certifies at the points of a family (numpy), and the rounding bounds.

    Attributes
    ----------
    decrease
        Largest ``λ_max`` of the decrease form scaled by ``diag(P) ⊕ I`` over the points and both axes
        (``< -bound``; :func:`scaled_eig_margins`).
    decrease_bound
        Largest rounding bound of it.
    min_eig_scaled, min_eig_bound
        Smallest eigenvalue of the diagonally scaled ``P_a(θ)`` and its rounding bound (``P ≻ 0``).
    mu_min
        Smallest ``μ(θ)`` (``>= 0``).
    inclusion
        Largest ``c (K̂_a - Ĝ_a) P_a⁻¹ (K̂_a - Ĝ_a)ᵀ`` (``<= 1``).
    reach_m
        Smallest reach over the points [m].
    eps
        Smallest saturation factor ``min(1, 1/‖ν‖)`` the region reaches (``‖ν‖ <= 1/eps`` inside it).
    failing : dict of ndarray
        Per axis, the indices of the points where the decrease, ``P ≻ 0``, ``μ >= 0`` or the inclusion fails.
    per_point : dict of ndarray
        Per axis, each point's decrease margin ``-λ_max - bound`` (negative: fails), for cutting planes.
    """

    decrease: float
    decrease_bound: float
    min_eig_scaled: float
    min_eig_bound: float
    mu_min: float
    inclusion: float
    reach_m: float
    eps: float
    failing: Mapping[str, np.ndarray]
    per_point: Mapping[str, np.ndarray]

    @property
    def ok(self) -> bool:
        """Every condition holds at every point, strict ones with a margin above their rounding bound."""
        return bool(-self.decrease > self.decrease_bound and self.min_eig_scaled > self.min_eig_bound
                    and self.mu_min >= 0.0 and self.inclusion <= 1.0 and self.reach_m > 0.0)

    def to_json(self) -> dict[str, float]:
        return {"decrease": self.decrease, "decrease_bound": self.decrease_bound,
                "min_eig_scaled": self.min_eig_scaled, "min_eig_bound": self.min_eig_bound, "mu_min": self.mu_min,
                "inclusion": self.inclusion, "reach_m": self.reach_m, "eps": self.eps}


def lure_check(region: LureRegion, box: ParameterBox, fam: CascadeFamily,
               axes: Sequence[str] = HORIZONTAL) -> LureCheck:
    """Re-check ``region`` at every point of ``fam`` for the given axes (module docstring), with numpy.

    The reach uses both axes' ``P`` at every point (a start may point anywhere), whatever ``axes`` holds, and the
    law's start (:func:`start_vector`, :func:`start_command`).
    """
    L = np.broadcast_to(np.asarray(fam.accel_limit, float), (len(fam),))
    dec, bnd, lam, lam_b, incl, fail, margin = [], [], [], [], [], {}, {}
    p00 = np.zeros(len(fam))
    k_max, kw_max = start_command(fam), np.zeros(len(fam))
    mu = None
    for a in HORIZONTAL:
        P, G, mu = region.at(box, fam.points, a)
        A, Bh, Kh = axis_loops(fam, a)
        v = start_vector(fam, a)
        p00 = np.maximum(p00, np.einsum("i,nij,j->n", v, P, v))
        try:
            W = np.linalg.inv(P)
        except np.linalg.LinAlgError:
            W = np.full_like(P, np.nan)
        KG = Kh - G
        inc = region.level * (KG @ W @ np.swapaxes(KG, -1, -2))[:, 0, 0]
        kw_max = np.maximum(kw_max, region.level * (Kh @ W @ np.swapaxes(Kh, -1, -2))[:, 0, 0])
        if a not in axes:
            continue
        F, F_abs = decrease_forms(A, Bh, Kh, P, G, mu, region.rho)
        lmax, bound = scaled_eig_margins(F, F_abs, A.shape[-1] + 2, margin_scale(P, 1))
        lp, lpb = lmi_checks.definite_margin(P)
        lp, lpb = np.atleast_1d(lp), np.atleast_1d(lpb)
        dec.append(lmax), bnd.append(bound), lam.append(lp), lam_b.append(lpb), incl.append(inc)
        margin[a] = -lmax - bound
        bad = (margin[a] <= 0) | (lp <= lpb) | (mu < 0) | ~(inc <= 1.0)
        fail[a] = np.flatnonzero(bad)
    reach = reach_at(p00, mu, region.level, L, k_max) if np.all(p00 > 0) else np.zeros(len(fam))
    with np.errstate(divide="ignore"):  # kw_max is 0 only where P is not positive definite, a failure above
        eps = np.minimum(1.0, 1.0 / np.sqrt(kw_max))
    cat = np.concatenate
    return LureCheck(decrease=float(np.max(cat(dec))), decrease_bound=float(np.max(cat(bnd))),
                     min_eig_scaled=float(np.min(cat(lam))), min_eig_bound=float(np.max(cat(lam_b))),
                     mu_min=float(np.min(mu)), inclusion=float(np.max(cat(incl))),
                     reach_m=float(np.min(reach)), eps=float(np.min(eps)), failing=fail, per_point=margin)


def coupled_parts(region: LureRegion, lyap: Mapping[str, RobustLyapunov], dims: Mapping[str, Sequence[int]],
                  box: ParameterBox, fam: CascadeFamily) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(T_m, P_ζ, Ĝ_ζ, μ)`` of the coupled loop at every point of ``fam``, in the subsystems' coordinates: the
    horizontal blocks from the region, the altitude and yaw blocks from their Lyapunov matrices."""
    Tm, _ = mode_transform(fam.state_names, fam.frame)
    n, N = Tm.shape[0], len(fam)
    Pz, Gz = np.zeros((N, n, n)), np.zeros((N, 2, n))
    mu = np.zeros(N)
    for name, sl in subsystem_blocks(fam.state_names).items():
        if name in HORIZONTAL:
            P, G, mu = region.at(box, fam.points, name)
            Pz[:, sl, sl] = P
            Gz[:, HORIZONTAL.index(name), sl] = G[:, 0]
        else:
            Pz[:, sl, sl] = affine_in(lyap[name].P, normalised_coordinates(box, fam.points, dims[name]))
    return Tm, Pz, Gz, mu


def coupled_decrease(region: LureRegion, lyap: Mapping[str, RobustLyapunov], dims: Mapping[str, Sequence[int]],
                     box: ParameterBox, fam: CascadeFamily) -> tuple[float, float]:
    """The decrease on the **coupled** 19-state loop at every point of ``fam``: ``(worst λ_max, its bound)``.

    ``V = xᵀ P x + 2 μ Φ(K x / L)`` with ``P = T_mᵀ diag(P_x, P_y, P_alt, P_yaw)(θ) T_m`` (the altitude and yaw
    blocks' Lyapunov matrices: they contract faster than ``ρ``), the 2-D command of the full loop and
    ``ξ = (x, ψ, ψ⁺) ∈ R^{19+2+2}``; certified where ``λ_max < -bound``.  The form is taken in the coordinates
    ``ζ = T_m x`` of the subsystems (an orthogonal congruence, which keeps the sign of every eigenvalue) so that
    the diagonal scaling sees each block in its own units; every off-block entry of ``T_m A_d T_mᵀ`` is kept,
    and the rounding of forming it is in the bound.
    """
    Tm, Pz, Gz, mu = coupled_parts(region, lyap, dims, box, fam)
    n, N = Tm.shape[0], len(fam)
    L = np.broadcast_to(np.asarray(fam.accel_limit, float), (N,))[:, None, None]
    A, B, K = Tm @ fam.A_d @ Tm.T, Tm @ fam.B * L, fam.K @ Tm.T / L
    F, F_abs = decrease_forms(A, B, K, Pz, Gz, mu, region.rho)
    # forming T A Tᵀ rounds each entry by at most n EPS (|T||A||T|ᵀ), large where the blocks' contributions cancel;
    # to first order that perturbs F by sy(|x⁺|ᵀ|P|, |δx⁺|): added to the entrywise bound in the same units
    aT = np.abs(Tm)
    dXp = np.concatenate([aT @ np.abs(fam.A_d) @ aT.T, aT @ np.abs(fam.B) * L, np.zeros((N, n, 2))], axis=-1)
    aXp = np.abs(next_state_rows(A, B))
    F_abs = F_abs + (n / (n + 4)) * _sy(np.abs(Pz) @ aXp, dXp)
    lmax, bound = scaled_eig_margins(F, F_abs, n + 4, margin_scale(Pz, 2))
    return float(np.max(lmax)), float(np.max(bound))


def lure_block(region: LureRegion, check_lmi: LureCheck, check_grid: LureCheck, coupled: tuple[float, float],
               lmi_points: Mapping[str, int]) -> dict[str, Any]:
    """The ``region_of_attraction.lure`` block of a certificate: the region and what it certifies."""
    return {"form": LURE_FORM, **region.to_json(), "lmi_points": {a: int(lmi_points[a]) for a in HORIZONTAL},
            "check_lmi_points": check_lmi.to_json(), "check_grid": check_grid.to_json(),
            "coupled_grid": {"decrease": coupled[0], "decrease_bound": coupled[1]}}


def _same(stated: Any, value: float, tol: float) -> bool:
    return (isinstance(stated, (int, float)) and not isinstance(stated, bool) and math.isfinite(float(stated))
            and abs(float(stated) - value) <= tol)


def _same_check(stated: Mapping[str, Any], got: LureCheck) -> bool:
    """Every stated number of a :class:`LureCheck` equals the recomputed one within its rounding (values, never
    argmax locations)."""
    g = got.to_json()
    tol = {"decrease": max(got.decrease_bound, 1e-12), "decrease_bound": 1e-6 * got.decrease_bound + 1e-300,
           "min_eig_scaled": max(got.min_eig_bound, 1e-9 * abs(got.min_eig_scaled)),
           "min_eig_bound": 1e-6 * got.min_eig_bound + 1e-300, "mu_min": 1e-9 * max(abs(got.mu_min), 1e-12),
           "inclusion": 1e-9, "reach_m": 1e-9 * got.reach_m, "eps": 1e-9 * got.eps}
    return set(stated) == set(g) and all(_same(stated[k], v, tol[k]) for k, v in g.items())


def check_lure_block(block: Mapping[str, Any], dims: Mapping[str, Sequence[int]], box: ParameterBox,
                     lmi: Mapping[str, CascadeFamily], grid: CascadeFamily, lyap: Mapping[str, RobustLyapunov]
                     ) -> tuple[bool, str, float]:
    """``verify``'s re-check of a stated Lur'e-Postnikov region: ``(ok, detail, reach [m])``.

    The region is read from its stated matrices; every condition is recomputed with numpy at each axis's LMI
    points (``lmi``), at the grid (both axes) and on the coupled loop at the grid, and every stated number
    compared.  ``reach`` is the smaller of the two recomputed reaches.
    """
    region = LureRegion.from_json(block, dims, axis_states(grid))
    ck = [lure_check(region, box, lmi[a], axes=[a]) for a in HORIZONTAL]
    cg = lure_check(region, box, grid)
    dec, bound = coupled_decrease(region, lyap, dims, box, grid)
    stated_coupled = block["coupled_grid"]
    ok = (block["form"] == LURE_FORM and all(c.ok for c in ck) and cg.ok and -dec > bound
          and {a: block["lmi_points"][a] for a in HORIZONTAL} == {a: len(lmi[a]) for a in HORIZONTAL}
          and _same_check(block["check_lmi_points"], merge_checks(ck)) and _same_check(block["check_grid"], cg)
          and set(stated_coupled) == {"decrease", "decrease_bound"}
          and _same(stated_coupled["decrease"], dec, max(bound, 1e-12))
          and _same(stated_coupled["decrease_bound"], bound, 1e-6 * bound + 1e-300))
    reach = min(min(c.reach_m for c in ck), cg.reach_m)
    detail = (f"decrease {max(c.decrease for c in ck + [cg]):.3g} (bound {max(c.decrease_bound for c in ck + [cg]):.2g}),"
              f" coupled {dec:.3g} (bound {bound:.2g}); inclusion {max(c.inclusion for c in ck + [cg]):.10f}; "
              f"mu >= {min(c.mu_min for c in ck + [cg]):.4g}; eps {min(c.eps for c in ck + [cg]):.4g}; "
              f"reach {reach:.6g} m")
    return bool(ok), detail, reach


def merge_checks(checks: Sequence[LureCheck]) -> LureCheck:
    """One :class:`LureCheck` of several: the worst of each number."""
    from dataclasses import replace

    return replace(checks[0], decrease=max(c.decrease for c in checks),
                   decrease_bound=max(c.decrease_bound for c in checks),
                   min_eig_scaled=min(c.min_eig_scaled for c in checks),
                   min_eig_bound=max(c.min_eig_bound for c in checks), mu_min=min(c.mu_min for c in checks),
                   inclusion=max(c.inclusion for c in checks), reach_m=min(c.reach_m for c in checks),
                   eps=min(c.eps for c in checks),
                   failing={a: v for c in checks for a, v in c.failing.items()},
                   per_point={a: v for c in checks for a, v in c.per_point.items()})
