"""The LMI of the Lur'e-Postnikov region of attraction (:mod:`nniquad.analysis.cascade.region`), and its search.

:func:`solve_lure` poses, for fixed level ``c`` and a target start ``r0``, the decrease ``F ⪯ -η I``, the
inclusion with the floor of ``P``, ``[[P - ε I, (K̂ - Ĝ)ᵀ], [K̂ - Ĝ, 1/c]] ⪰ 0`` (it implies ``P ⪰ ε I`` and the
inclusion), ``μ >= 0`` at every LMI point of each axis, and minimises
the largest level ``t`` of the start ``r0`` (the sector multiplier is 1: ``V`` is scaled freely, and ``c`` is
searched instead).  It is solved in coordinates ``x = D x̃`` in which the linear loop contracts in the
Euclidean norm (a congruence: it changes no answer in exact arithmetic).  :func:`lure_region` searches ``c`` on
the centre point alone (milliseconds per solve), solves at every LMI point, and adds the grid points where the
numpy check fails to the LMI points (cutting planes) until the whole grid passes; a level that one corner of
the box alone cannot support is skipped before its solves at every point.  Nothing the solver returns
is taken on trust: :func:`nniquad.analysis.cascade.region.lure_check` decides.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from nniquad.analysis.cascade.box import ParameterBox, normalised_coordinates
from nniquad.analysis.cascade.conic import ConicProblem, sym_basis
from nniquad.analysis.cascade.family import SUBSYSTEMS, CascadeFamily, subsystem_of, take_points
from nniquad.analysis.cascade.lyapunov import RobustLyapunov, affine_in, block_loops, mirror_blocks
from nniquad.analysis.cascade.region import (
    HORIZONTAL,
    LureCheck,
    LureRegion,
    axis_loops,
    coupled_decrease,
    features,
    form_parts,
    huber,
    lure_block,
    lure_check,
    merge_checks,
    n_features,
    start_command,
    start_vector,
)
from nniquad.config import (
    CASCADE_LURE_CUT_POINTS,
    CASCADE_LURE_CUT_ROUNDS,
    CASCADE_LURE_LEVELS,
    CASCADE_LURE_MARGIN,
    CASCADE_ROA_DECAY_FRACTION,
)

__all__ = ["solve_lure", "lure_region", "LureSearch", "lure_section", "corner_points"]

#: Smallest eigenvalue of ``P̃`` in the solver's coordinates, and the floor of ``μ`` at the LMI points.
_P_FLOOR = 1e-7
_MU_FLOOR = 1e-6
#: Clarabel's relative gap and feasibility tolerance for the region LMI (``CASCADE_LURE_MARGIN`` is a hundred times
#: more: the numpy check, not the solver's accuracy, decides).
_SOLVER_TOL = 1e-6
#: The stated level is the solver's ``c`` lowered until the inclusion holds with this relative margin.
_INCLUSION_MARGIN = 1e-9


def solver_coordinates(P: np.ndarray, k_pos: float, L: float) -> np.ndarray:
    """``D`` with ``x = D x̃``: ``P`` becomes a multiple of the identity, and a position of ``L / k_pos`` (where the
    command of a position offset reaches the limit) has ``x̃`` of order one."""
    D = np.linalg.inv(np.linalg.cholesky(0.5 * (P + P.T)).T)
    return D * (L / k_pos) / abs(D[0, 0])


def coordinate_choices(A: np.ndarray, P: np.ndarray, k_pos: float, L: float) -> list[np.ndarray]:
    """The solver's coordinates to try, in order (:func:`solver_coordinates` of each matrix).

    First those in which the linear loop ``A`` contracts in ``‖x̃‖`` (``dlyap(Aᵀ, I)``), then those of the axis's
    robust Lyapunov matrix ``P``: Clarabel stalls on some designs in one and not the other (the paper's design
    in the second, a design with a fast attitude loop in the first, whose motor state it scales by 3e4).
    Any choice is a congruence, which changes no answer in exact arithmetic.
    """
    with warnings.catch_warnings():  # an ill-conditioned Lyapunov equation is still a usable scaling
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        first = sla.solve_discrete_lyapunov(A.T, np.eye(A.shape[-1]))
    return [solver_coordinates(first, k_pos, L), solver_coordinates(P, k_pos, L)]


#: Solver statuses after which the next coordinates are tried (an infeasible level is left at once).
_NUMERICAL = ("NumericalError", "InsufficientProgress", "MaxIterations", "panic")


@dataclass(frozen=True)
class AxisData:
    """One axis at its LMI points: loops, coordinates, saturation levels (``L`` per point), the position gain
    ``k_pos`` (the solver's scaling) and the start per metre (:func:`nniquad.analysis.cascade.region.start_vector`)."""

    A: np.ndarray
    Bh: np.ndarray
    Kh: np.ndarray
    theta: np.ndarray
    theta_mult: np.ndarray
    L: np.ndarray
    k_pos: float
    start: np.ndarray | None = None  # the start per metre (region.start_vector); None: the position alone

    def take(self, idx: np.ndarray) -> "AxisData":
        return AxisData(self.A[idx], self.Bh[idx], self.Kh[idx], self.theta[idx], self.theta_mult[idx], self.L[idx],
                        self.k_pos, self.start)

    def constant(self) -> "AxisData":
        """The same points without their coordinates: the LMI then has constant ``P, Ĝ, μ`` (one feature)."""
        return AxisData(self.A, self.Bh, self.Kh, self.theta[:, :0], self.theta_mult[:, :0], self.L, self.k_pos,
                        self.start)

    def join(self, other: "AxisData") -> "AxisData":
        cat = np.concatenate
        return AxisData(cat([self.A, other.A]), cat([self.Bh, other.Bh]), cat([self.Kh, other.Kh]),
                        cat([self.theta, other.theta]), cat([self.theta_mult, other.theta_mult]),
                        cat([self.L, other.L]), self.k_pos, self.start)


def axis_data(fam: CascadeFamily, box: ParameterBox, axis: str, dims: Sequence[int],
              mult_dims: Sequence[int]) -> AxisData:
    """:class:`AxisData` of ``axis`` at every point of ``fam``."""
    A, Bh, Kh = axis_loops(fam, axis)
    v = start_vector(fam, axis)  # the position alone, or with the delay line full (the command of the start: K v)
    return AxisData(A, Bh, Kh, normalised_coordinates(box, fam.points, dims), normalised_coordinates(box, fam.points, mult_dims),
                    np.broadcast_to(np.asarray(fam.accel_limit, float), (len(fam),)).copy(),
                    abs(float((subsystem_of(fam, axis)[3] @ v)[0])), v)


def solve_lure(axes: Mapping[str, AxisData], D: Mapping[str, np.ndarray], level: float, r0: float, rho: float,
               k_max: float, eta: float = CASCADE_LURE_MARGIN, reg: float = 0.0) -> tuple[str, dict | None]:
    """Solve the region LMI (module docstring) for the given axes with a shared ``μ(θ)``.

    Returns the solver's status and, when (almost) solved, ``{"P": {a: ...}, "G": {a: ...}, "mu": ...,
    "t": ...}`` in the original coordinates (coefficients of :func:`nniquad.analysis.cascade.region.features`).
    """
    prob = ConicProblem()
    nfm = features(next(iter(axes.values())).theta_mult[:1]).shape[1]
    i_mu = prob.variables(nfm)
    i_t = prob.variables(1)
    var = {}
    for a, d in axes.items():
        N, n = d.A.shape[0], d.A.shape[-1]
        Dm = D[a]
        Di = np.linalg.inv(Dm)
        fP, fm = features(d.theta), features(d.theta_mult)
        nf = fP.shape[1]
        E = sym_basis(n)
        nE = E.shape[0]
        iP = prob.variables(nf * nE).reshape(nf, nE)
        iG = prob.variables(nf * n).reshape(nf, n)
        var[a] = (iP, iG, Di, E, nf, n)
        parts = form_parts(Di @ d.A @ Dm, Di @ d.Bh, d.Kh @ Dm)
        X, Xp, ps = parts["X"], parts["Xp"], parts["ps"]
        k = n + 2
        FP = np.einsum("nai,eab,nbj->neij", Xp, E, Xp) - rho * rho * np.einsum("ai,eab,bj->eij", X, E, X)[None]
        GX = np.stack([ps.T @ X[l:l + 1] + X[l:l + 1].T @ ps for l in range(n)])
        # everything divided by c (P̂ = P/c, μ̂ = μ/c, the sector multiplier 1/c): the numbers are of order one
        Fz = np.concatenate([np.einsum("nf,neij->nfeij", fP, FP).reshape(N, nf * nE, k, k),
                             np.einsum("nf,lij->nflij", fP, GX).reshape(N, nf * n, k, k) / level,
                             np.einsum("nf,nij->nfij", fm, parts["Mmu"])], axis=1)
        # the margin: F ⪯ -η (diag(P) ⊕ I), diag(P) taken in the original coordinates (the metric of verify)
        Dg = np.einsum("ai,eab,bj->eij", Di, E, Di) * np.eye(n)[None]  # diag(D⁻ᵀ E_e D⁻¹)
        Mg = np.zeros((nE, k, k))
        Mg[:, :n, :n] = np.einsum("ai,eab,bj->eij", Dm, Dg, Dm)
        Fz[:, :nf * nE] += eta * np.einsum("nf,eij->nfeij", fP, Mg).reshape(N, nf * nE, k, k)
        margin_psi = np.zeros((k, k))
        margin_psi[n:, n:] = np.eye(2)
        prob.psd((-parts["Fc"] - eta * margin_psi[None]) / level, np.concatenate([iP.ravel(), iG.ravel(), i_mu]),
                 -Fz)
        PE = np.einsum("nf,eij->nfeij", fP, E).reshape(N, nf * nE, n, n)
        Kt = (d.Kh @ Dm)[:, 0, :]
        # the floor of P̂ sits in the inclusion's corner: [[P̂ - εI, (K̂ - Ĝ)ᵀ], [K̂ - Ĝ, 1]] ⪰ 0 gives P̂ ⪰ εI and
        # (a hair more than) the inclusion in one matrix inequality, a quarter fewer rows than two
        I0 = np.zeros((N, n + 1, n + 1))
        I0[:, :n, :n] = -_P_FLOOR / level * np.eye(n)
        I0[:, n, n] = 1.0
        I0[:, :n, n] = I0[:, n, :n] = Kt
        IP = np.zeros((N, nf * nE, n + 1, n + 1))
        IP[:, :, :n, :n] = PE
        IG = np.zeros((N, nf, n, n + 1, n + 1))
        for l in range(n):
            IG[:, :, l, l, n] = IG[:, :, l, n, l] = -fP
        prob.psd(I0, np.concatenate([iP.ravel(), iG.ravel()]),
                 np.concatenate([IP, IG.reshape(N, nf * n, n + 1, n + 1)], axis=1))
        prob.nonnegative(np.full(N, -_MU_FLOOR / level), i_mu, fm)
        e = Di[:, 0] if d.start is None else Di @ d.start
        Pe = np.einsum("i,eij,j->e", e, E, e)
        phi = huber(k_max * r0 / d.L)
        prob.nonnegative(np.zeros(N), np.concatenate([iP.ravel(), i_mu, i_t]),
                         np.concatenate([-(r0 * r0) * np.einsum("nf,e->nfe", fP, Pe).reshape(N, -1),
                                         -2.0 * phi[:, None] * fm, np.ones((N, 1))], axis=1))
    cost = np.zeros(prob.n)
    cost[i_t] = 1.0
    for a, (iP, iG, Di, E, nf, n) in var.items():  # a little of the trace of P̂(0): a bounded, unique answer
        cost[iP[0]] += reg * np.trace(E, axis1=1, axis2=2)
    status, z = prob.solve(cost, tol=_SOLVER_TOL)
    if z is None:
        return status, None
    out = {"P": {}, "G": {}, "mu": level * z[i_mu], "t": level * float(z[i_t][0])}
    for a, (iP, iG, Di, E, nf, n) in var.items():
        Pt = level * np.einsum("fe,eij->fij", z[iP], E)
        out["P"][a] = 0.5 * (Di.T @ Pt @ Di + np.swapaxes(Di.T @ Pt @ Di, -1, -2))
        out["G"][a] = (z[iG] @ Di)[:, None, :]
    return status, out


@dataclass(frozen=True)
class LureSearch:
    """The answer of :func:`lure_region`.

    Attributes
    ----------
    region
        The region (``None``: none passed the numpy check).
    check_lmi, check_grid
        :class:`nniquad.analysis.cascade.region.LureCheck` at the LMI points and at the grid.
    grid_points_added
        Grid points added to the LMI points by the cutting planes, per axis.
    levels_tried
        ``(c, reach at the centre point [m])`` of the level search.
    status
        The last solver status.
    """

    region: LureRegion | None
    check_lmi: LureCheck | None
    check_grid: LureCheck | None
    grid_points_added: Mapping[str, int]
    levels_tried: tuple[tuple[float, float], ...]
    status: str


def _mirror_region(sol: dict, d: np.ndarray) -> dict:
    """y's ``P, Ĝ`` from x's for a mirrored vehicle (``A_y = D A_x D``, ``K_y = K_x D``): ``D P D``, ``Ĝ D``."""
    return {**sol, "P": {**sol["P"], "y": d[None, :, None] * sol["P"]["x"] * d[None, None, :]},
            "G": {**sol["G"], "y": sol["G"]["x"] * d[None, None, :]}}


def _region(sol: dict, level: float, rho: float, dims, mult_dims) -> LureRegion:
    return LureRegion(P=sol["P"], G=sol["G"], mu=np.asarray(sol["mu"], float), level=level, rho=rho,
                      dims={a: tuple(dims[a]) for a in HORIZONTAL}, mult_dims=tuple(mult_dims))


def _settled_level(region: LureRegion, box: ParameterBox, fams: Sequence[CascadeFamily]) -> LureRegion:
    """The region with its level lowered so that the inclusion holds at every point of ``fams`` (the solver's
    answer meets it only to its tolerance)."""
    worst = max(lure_check(region, box, f).inclusion for f in fams)
    if worst <= 1.0 - _INCLUSION_MARGIN:
        return region
    from dataclasses import replace

    return replace(region, level=region.level * (1.0 - _INCLUSION_MARGIN) / worst)


def lure_region(lmi: Mapping[str, CascadeFamily], grid: CascadeFamily, box: ParameterBox,
                dims: Mapping[str, Sequence[int]], rho: float, lyap: Mapping[str, RobustLyapunov], *,
                mirror: np.ndarray | None = None,
                levels: Sequence[float] = CASCADE_LURE_LEVELS, rounds: int = CASCADE_LURE_CUT_ROUNDS,
                cut_points: int = CASCADE_LURE_CUT_POINTS, attempts: int = 3,
                eta: float = CASCADE_LURE_MARGIN) -> LureSearch:
    """The widest Lur'e-Postnikov region found, checked with numpy at the LMI points and on the grid.

    Parameters
    ----------
    lmi
        Each horizontal axis's family at its LMI points.
    grid
        The family at the grid points (both axes are checked there).
    box, dims
        The box and each axis's coordinates.
    rho
        Decrease factor per sample (module docstring of :mod:`nniquad.analysis.cascade.region`).
    lyap
        The axes' Lyapunov blocks (their ``P`` at the centre sets the solver's coordinates).
    mirror
        Signs ``d`` when y mirrors x (:func:`nniquad.analysis.cascade.lyapunov.mirror_blocks`): only x is solved, and
        y's matrices are x's mirrored (checked on y's own loops like any other answer).
    levels
        The levels ``c`` tried at the centre point; the best one and its neighbours at half steps are then used.
    rounds, cut_points
        Cutting-plane rounds, and failing grid points added per axis and round.
    attempts
        Levels tried at every LMI point, best centre reach first, until one passes.
    eta
        The decrease margin (:func:`solve_lure`).
    """
    mult = tuple(sorted(set(dims["x"]) & set(dims["y"])))
    data = {a: axis_data(lmi[a], box, a, dims[a], mult) for a in HORIZONTAL}
    gdata = {a: axis_data(grid, box, a, dims[a], mult) for a in HORIZONTAL}
    k_max = start_command(lmi["x"])  # the start's command per metre: the controller's take-over state included
    solved = ("x",) if mirror is not None else HORIZONTAL
    centre = {a: int(np.argmin(np.sum(data[a].theta ** 2, axis=1))) for a in HORIZONTAL}
    choices = {a: coordinate_choices(data[a].A[centre[a]],
                                     affine_in(lyap[a].P, data[a].theta[centre[a]:centre[a] + 1])[0], data[a].k_pos,
                                     float(data[a].L[centre[a]])) for a in solved}
    D_all = [{a: choices[a][i] for a in solved} for i in range(2)]
    r_lin = float(min(np.min(d.L) for d in data.values())) / k_max  # where the start's command saturates

    def region_of(sol: dict, level: float, fams: Sequence[CascadeFamily], constant: bool = False) -> LureRegion:
        full = _mirror_region(sol, mirror) if mirror is not None else sol
        used, used_mult = ({a: () for a in HORIZONTAL}, ()) if constant else (dims, mult)
        return _settled_level(_region(full, level, rho, used, used_mult), box, fams)

    # ---- the level c, on the centre point alone (constant P, Ĝ, μ: one point fixes no dependence on θ)
    cdata = {a: data[a].take(np.array([centre[a]])).constant() for a in solved}
    cfams = {a: take_points(lmi[a], np.array([centre[a]])) for a in HORIZONTAL}

    def centre_reach(level: float) -> float:
        for D in D_all:  # the next coordinates when the solver stalls or its answer fails the numpy check
            _, sol = solve_lure(cdata, D, level, 10.0 * r_lin, rho, k_max, eta)
            if sol is None:
                continue
            region = region_of(sol, level, list(cfams.values()), constant=True)
            checks = [lure_check(region, box, cfams[a], axes=[a]) for a in HORIZONTAL]
            if all(c.ok for c in checks):
                return min(c.reach_m for c in checks)
        return 0.0

    tried = [(float(c), centre_reach(float(c))) for c in levels]
    best_c, best_r = max(tried, key=lambda t: t[1])
    if best_r <= 0.0:
        return LureSearch(None, None, None, {a: 0 for a in HORIZONTAL}, tuple(tried), "no level certifies the centre")
    tried += [(c, centre_reach(c)) for c in (best_c / math.sqrt(2.0), best_c * math.sqrt(2.0))]
    # ---- every LMI point, then cutting planes from the grid; a level whose solve fails gives way to the next best
    status = "not solved"
    found: LureSearch | None = None
    for best_c, best_r in sorted((t for t in tried if t[1] > 0), key=lambda t: -t[1])[:attempts]:
        if _refused_at_a_corner(data, solved, D_all, best_c, 0.9 * best_r, rho, k_max, eta):
            status = f"level {best_c:.6g} is infeasible at a corner of the box"
            continue
        # constant P, Ĝ, μ first (a few variables, solved in a second: enough on a small box), then quadratic
        for constant in (True, False):
            got, status = _solve_with_cuts(data, gdata, lmi, grid, solved, D_all, best_c, 0.9 * best_r, rho, k_max,
                                           eta, rounds, cut_points, mirror, region_of, box, constant)
            if got is not None and (found is None or got.check_grid.reach_m > found.check_grid.reach_m):
                found = LureSearch(got.region, got.check_lmi, got.check_grid, got.grid_points_added, tuple(tried),
                                   f"{status} at level {best_c:.6g} ({'constant' if constant else 'quadratic'})")
        if found is not None:
            return found
    return LureSearch(None, None, None, {a: 0 for a in HORIZONTAL}, tuple(tried), status)


def corner_points(theta: np.ndarray) -> np.ndarray:
    """Indices of the points of ``theta`` at the corners of their θ-cube (each coordinate at its largest ``|θ_j|``);
    every point when there is no coordinate."""
    if theta.shape[1] == 0:
        return np.arange(theta.shape[0])
    a = np.abs(theta)
    return np.flatnonzero(np.all(np.isclose(a, a.max(axis=0), rtol=1e-9, atol=0.0), axis=1))


def _refused_at_a_corner(data: Mapping[str, AxisData], solved: Sequence[str], D_all: Sequence[Mapping[str, np.ndarray]],
                         level: float, r0: float, rho: float, k_max: float, eta: float) -> bool:
    """Whether the region LMI at ``level`` is infeasible at one LMI point alone (a corner of the box first).

    Any answer of the LMI at every point, quadratic in θ or constant, is at each point an answer of that point's
    LMI with constant ``P, Ĝ, μ``: a point whose own LMI the solver finds infeasible makes the level infeasible
    for both, and its solves (seconds each, where a corner's takes milliseconds) are skipped.  Only an answer
    of infeasibility counts, as in :func:`_solve_with_cuts`; a stall in every coordinate choice screens nothing.
    The corners are where the box's extremes meet, where a level fails first in practice.
    """
    for a in solved:
        d = data[a]
        for i in corner_points(d.theta):
            one = {a: d.take(np.array([i])).constant()}
            for D in D_all:
                status, sol = solve_lure(one, {a: D[a]}, level, r0, rho, k_max, eta)
                if sol is not None or status not in _NUMERICAL:
                    break
            if sol is None and status not in _NUMERICAL:
                return True
    return False


def _padded(sol: dict, data: Mapping[str, AxisData]) -> dict:
    """A constant answer (one feature) in the quadratic basis of the region: zero coefficients beyond the first."""
    def pad(v: np.ndarray, q: int) -> np.ndarray:
        return np.concatenate([v, np.zeros((n_features(q) - 1,) + v.shape[1:])])

    return {"P": {a: pad(v, data[a].theta.shape[1]) for a, v in sol["P"].items()},
            "G": {a: pad(v, data[a].theta.shape[1]) for a, v in sol["G"].items()},
            "mu": pad(np.asarray(sol["mu"]), data["x"].theta_mult.shape[1])}


def _solve_with_cuts(data, gdata, lmi, grid, solved, D_all, level, r0, rho, k_max, eta, rounds, cut_points, mirror,
                     region_of, box, constant) -> tuple[LureSearch | None, str]:
    """One level: the LMI at every LMI point, then cutting planes until the grid passes (``None``: it did not)."""
    cut = (lambda d: d.constant()) if constant else (lambda d: d)
    cur = {a: cut(data[a]) for a in solved}
    grid_data = {a: cut(g) for a, g in gdata.items()}
    added = {a: 0 for a in HORIZONTAL}
    status = "not solved"
    for _ in range(rounds + 1):
        region = check_grid = None
        for D in list(D_all):  # the next coordinates when the solver stalls or its answer fails at an LMI point
            status, sol = solve_lure(cur, D, level, r0, rho, k_max, eta)
            if sol is None:
                if status in _NUMERICAL:
                    continue
                return None, status
            if constant:  # the constant answer in the quadratic basis of the region
                sol = _padded(sol, data)
            region = region_of(sol, level, [lmi["x"], lmi["y"], grid])
            checks_lmi = [lure_check(region, box, lmi[a], axes=[a]) for a in HORIZONTAL]
            if all(c.ok for c in checks_lmi):
                check_grid = lure_check(region, box, grid)
                # a cut adds a few points to the same problem: the coordinates that solved it are tried first
                D_all = [D] + [other for other in D_all if other is not D]
                break
            status += "; the numpy check fails at an LMI point"
        if check_grid is None:
            return None, status
        if check_grid.ok:
            return LureSearch(region, merge_checks(checks_lmi), check_grid, added, (), status), status
        _cut(cur, check_grid, grid_data, solved, mirror, cut_points, added)
    return None, status + "; the grid still fails after the cutting planes"


def lure_section(fam: CascadeFamily, pts: Mapping[str, np.ndarray], lyap: Mapping[str, RobustLyapunov],
                 grid: CascadeFamily, box: ParameterBox, dims: Mapping[str, Sequence[int]]
                 ) -> tuple[dict[str, Any] | None, dict[str, Any]]:
    """The ``region_of_attraction.lure`` block of a section (``None``: no region passed), and the search's record.

    ``fam`` is stacked as ``[nominal, LMI points of each subsystem in SUBSYSTEMS order, ...]`` (as
    :func:`nniquad.analysis.cascade.section._certify_box` builds it); ``ρ`` is
    ``exp(-CASCADE_ROA_DECAY_FRACTION × the horizontal blocks' slower decay × T)``.
    """
    start, lmi = 1, {}
    for name in SUBSYSTEMS:
        if name in HORIZONTAL:
            lmi[name] = take_points(fam, np.arange(start, start + pts[name].shape[0]))
        start += pts[name].shape[0]
    loops = block_loops(fam, box, pts, dims)
    mirror = mirror_blocks(*((loops[a][0], subsystem_of(fam, a)[3], loops[a][1]) for a in HORIZONTAL))
    rho = math.exp(-CASCADE_ROA_DECAY_FRACTION * min(lyap[a].decay_rate_1_s for a in HORIZONTAL) * fam.T)
    search = lure_region(lmi, grid, box, dims, rho, lyap, mirror=mirror)
    record = {"levels_tried": [{"level": c, "centre_reach_m": r} for c, r in search.levels_tried],
              "grid_points_added": dict(search.grid_points_added), "mirrored": mirror is not None,
              "solver_status": search.status}
    if search.region is None:
        return None, record
    coupled = coupled_decrease(search.region, lyap, dims, box, grid)
    if not -coupled[0] > coupled[1]:
        record["solver_status"] += "; the coupled check failed"
        return None, record
    return lure_block(search.region, search.check_lmi, search.check_grid, coupled,
                      {a: len(lmi[a]) for a in HORIZONTAL}), record


def _cut(cur: dict, check_grid: LureCheck, gdata: Mapping[str, AxisData], solved: Sequence[str],
         mirror: np.ndarray | None, cut_points: int, added: dict) -> None:
    """Cutting planes: the worst failing grid points join ``cur``, the LMI points of the axis solved for them."""
    for target in solved:  # the worst failing grid points join the LMI points of the axis solved for them
        new, margin = [], []
        for a in HORIZONTAL:
            if (a if a in solved else "x") != target or not len(check_grid.failing[a]):
                continue
            bad = check_grid.failing[a]
            pts = gdata[a].take(bad)
            if a not in solved:  # y mirrors x: y's points, in x's coordinates
                pts = AxisData(mirror[:, None] * pts.A * mirror[None, :], mirror[:, None] * pts.Bh,
                               pts.Kh * mirror[None, :], pts.theta, pts.theta_mult, pts.L, pts.k_pos,
                               None if pts.start is None else pts.start * mirror)
            new.append(pts)
            margin.append(check_grid.per_point[a][bad])
        if not new:
            continue
        pts = new[0]
        for more in new[1:]:
            pts = pts.join(more)
        margin = np.concatenate(margin)
        # an axis sees only its own coordinates: many grid points are one point of the axis, and a mirrored
        # y point is an x point; each is added once, the worst first
        key = np.round(pts.theta, 9)
        _, first = np.unique(key, axis=0, return_index=True)
        known = {tuple(r) for r in np.round(cur[target].theta, 9)}
        first = np.array([i for i in first if tuple(key[i]) not in known], int)
        worst = _spread_worst(pts.theta[first], margin[first], cut_points)
        cur[target] = cur[target].join(pts.take(first[worst]))
        added[target] += len(worst)


def _spread_worst(theta: np.ndarray, margin: np.ndarray, count: int) -> np.ndarray:
    """Indices of at most ``count`` failing points: the worst first, then each the farthest (in θ) from those chosen.

    The failing grid points of a round crowd around a few spots of the box; the worst ``count`` of them are
    mostly neighbours of one another, and the next round fails at the spots they left out.  Spreading the cut
    over the failing set covers every spot in the round.  Ties in distance go to the worse margin.
    """
    order = np.argsort(margin, kind="stable")
    if len(order) <= count:
        return order
    theta, chosen = theta[order], [0]
    dist = np.sum((theta - theta[0]) ** 2, axis=1)
    while len(chosen) < count:
        nxt = int(np.argmax(dist))  # argmax keeps the first of equal distances: the worse margin
        chosen.append(nxt)
        dist = np.minimum(dist, np.sum((theta - theta[nxt]) ** 2, axis=1))
    return order[np.array(chosen)]
