"""``verify``'s re-check of a certificate's ``cascade`` section from the design alone.

Every system matrix is rebuilt from the design, the stated rate and the stated box; every stated number is
recomputed with numpy and compared (values within their rounding bounds, never where an argmax tie breaks).
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nniquad.analysis.cascade.box import POINT_NAMES, ParameterBox, grid_subset, tilt_accel_limit
from nniquad.analysis.cascade.box_proof import (
    BOX_PROOF_METHOD,
    ENCLOSURE,
    allowed_box_rhos,
    box_proof,
    full_affine_P,
    grid_point_proofs,
    lyapunov_point_proofs,
)
from nniquad.analysis.cascade.family import (
    COUPLING_TOL,
    SUBSYSTEMS,
    coupling,
    family_cached,
    relevance_consistent,
    relevance_points,
    subsystems,
    take_points,
)
from nniquad.analysis.cascade.lyapunov import (
    GridCheck,
    RobustLyapunov,
    assemble_P,
    block_loops,
    checked_grid_size,
    grid_check,
    point_index,
    witness_margins,
)
from nniquad.analysis.cascade.lure_proof import lure_proofs
from nniquad.analysis.cascade.region import (
    HORIZONTAL,
    LureRegion,
    axis_states,
    check_lure_block,
    linear_zone_reach,
    roa_note,
)
from nniquad.analysis.cascade.section import (
    LMI_POINTS_PER_AXIS,
    LYAPUNOV_COVERAGE,
    LYAPUNOV_COVERAGE_GRID_ONLY,
    LYAPUNOV_FORM,
    MARGIN_POINTS,
    anti_windup_matrix,
    margin_fields,
    margin_model,
    model_text,
)
from nniquad.analysis.fast_margins import fast_cascade_margins
from nniquad.analysis.sampled import control_period
from nniquad.analysis.verified.inequalities import ProofRow
from nniquad.config import CASCADE_GRID_POINTS_PER_AXIS, XI0_M
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CascadeError
from nniquad.laws.base import GainBlock
from nniquad.model.vehicle import Vehicle
from nniquad.sim import state_names

__all__ = ["check_cascade_section", "check_cascade_rows", "stated_delay"]


def _close(a: Any, b: Any, rtol: float = 1e-9) -> bool:
    try:
        A, B = np.asarray(a, float), np.asarray(b, float)
    except (TypeError, ValueError):
        return False
    if A.shape != B.shape:
        return False
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        return bool(np.array_equal(A, B))
    return bool(np.all(np.abs(A - B) <= rtol * np.maximum(np.abs(B), 1.0) + 1e-300))  # True when empty


def _same_worst(stated: Mapping[str, Any], gc: GridCheck, points: np.ndarray) -> bool:
    """The stated worst values equal the recomputed ones, and each stated worst point is a grid point whose own
    value equals the recomputed worst, all within the rounding bound (never *which* of tied points is stated:
    many grid points tie to rounding, and another machine's argmax may pick another of them)."""
    tol = max(1e-9, gc.rounding_bound)
    for value_key, point_key, values in (("worst_rho", "worst_point", gc.rho_all),
                                         ("worst_spectral_radius", "worst_spectral_point", gc.spectral_all)):
        worst = float(np.max(values))
        i = point_index(points, [stated[point_key][n] for n in POINT_NAMES])
        if not (_is_number(stated.get(value_key)) and abs(float(stated[value_key]) - worst) <= tol
                and i is not None and abs(float(values[i]) - worst) <= tol):
            return False
    return _is_number(stated.get("worst_margin")) and abs(float(stated["worst_margin"]) - (1.0 - gc.worst_rho)) <= tol


#: A stated rounding bound equals the recomputed one within this relative tolerance.  The verdicts use the
#: recomputed bound; a jitter of the stored ``P`` far below every tolerance (relative 1e-12) moves the bound of an
#: ill-conditioned ``P`` (λ_min/λ_max ≈ 1e-8) by about 1e-4 of itself.
BOUND_RTOL = 1e-3
#: A stated smallest eigenvalue of a diagonally scaled ``P`` (unit diagonal: eigenvalues at most n) equals the
#: recomputed one within this absolute tolerance: far above a relative 1e-12 jitter of ``P``, far below a margin.
SCALED_EIG_ATOL = 1e-9


def _stated_margin_ok(key: str, stated: Any, computed: float) -> bool:
    """A stated rounding margin (:func:`nniquad.analysis.cascade.section.margin_fields`) equals the recomputed one.

    Each against its own scale, with no absolute floor of 1 (``_close`` has one, for matrix entries rebuilt by
    finite differences; it would accept any stated bound below it).
    """
    if not _is_number(stated):
        return False
    if key == "min_eig_scaled":
        return abs(float(stated) - computed) <= SCALED_EIG_ATOL
    return abs(float(stated) - computed) <= BOUND_RTOL * abs(computed)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class _FirstFailure(Exception):
    """Raised by a ``fail_fast`` re-check at its first failed row (the rows so far are the answer)."""


#: ``cache(kind, inputs, compute)``: ``compute()``, or an earlier result for the same kind and exact JSON inputs.
Cache = Callable[[str, Any, Callable[[], Any]], Any]


def _no_cache(kind: str, inputs: Any, compute: Callable[[], Any]) -> Any:
    return compute()


def check_cascade_section(section: Mapping[str, Any], vehicle: Vehicle, gains: GainBlock,
                          inner: InnerLoopGains, *, tilt_limit_deg: float, xi0_m: Sequence[float] = XI0_M,
                          fail_fast: bool = False, cache: Cache | None = None,
                          thorough: bool = False) -> list[tuple[str, bool, str]]:
    """:func:`check_cascade_rows` as ``(name, ok, detail)``: ``ok`` when the row's numbers are recomputed and its
    inequalities proven."""
    rows = check_cascade_rows(section, vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, xi0_m=xi0_m,
                              fail_fast=fail_fast, cache=cache, thorough=thorough)
    return [(name, ok and all(r.outcome == "proven" for r in proofs), detail) for name, ok, detail, proofs in rows]


def check_cascade_rows(section: Mapping[str, Any], vehicle: Vehicle, gains: GainBlock,
                       inner: InnerLoopGains, *, tilt_limit_deg: float, xi0_m: Sequence[float] = XI0_M,
                       fail_fast: bool = False, cache: Cache | None = None,
                       thorough: bool = False) -> list[tuple[str, bool, str, tuple[ProofRow, ...]]]:
    """Re-check a ``cascade`` section from the design alone (cheap checks first).

    Every system matrix is rebuilt from ``vehicle``, ``gains``, ``inner``, the
    stated rate and the stated box (no stored ``A`` is trusted); the stored
    nominal matrices are compared with the rebuilt ones; every Lyapunov
    condition is re-checked with numpy at the LMI points (contraction of
    ``P(θ)`` equal to the stated ``ρ < 1``, ``P(θ) ≻ 0`` on the cube's corners);
    the grid check is re-run and every stated number compared (relative 1e-9);
    the region of attraction is recomputed from its stated matrices (method
    ``lure``: :func:`nniquad.analysis.cascade.region.check_lure_block`) and
    ``start_certified`` from the reach and ``xi0_m`` (the certificate's start,
    by default :data:`nniquad.config.XI0_M` as for :func:`cascade_section`);
    the margins are recomputed at the stated worst vertices.  The box search (``box_search``) is a record, not re-run: the
    certified box is what is checked.

    Every strict inequality (contraction at the LMI points and the grid points, ``P(θ) ≻ 0`` on the θ-cube) is
    proven with a verified Cholesky decomposition (:mod:`nniquad.analysis.cascade.box_proof`).  With ``thorough``
    the Lyapunov inequality is also proven over every cell of the box (:func:`box_proof`, several seconds) and
    compared with the stated ``box_proof``; without it a stated ``box_proof`` is checked for form only.

    With ``fail_fast`` the re-check stops at its first failed row (``verify --fail-fast`` and the tamper loop: a
    refusal needs one failed check, and the grid, the region and the margins come last because they cost most).

    ``cache`` (:func:`nniquad.certificates.check_record.memo` in ``verify``) may hand back an earlier result of one of
    the three costly recomputations (the grid check, the region of attraction, the margins) for the same exact
    inputs: the design, the stated box and grid size, and the stated fields that recomputation reads.  Each is a
    pure function of those inputs, so verifying many edits of one section redoes only what an edit touches.

    Returns
    -------
    list of (name, ok, detail, proofs)
        Every row, in order; with ``fail_fast`` the rows up to and including the first failed one.  ``proofs``
        are the row's proven inequalities (empty for a row of recomputed numbers); ``ok`` is the verdict on
        the recomputed numbers alone (the row passes only if its proofs are proven too).
    """
    out: list[tuple[str, bool, str, tuple[ProofRow, ...]]] = []

    def add(name: str, ok: bool, detail: str, proofs: Sequence[ProofRow] = ()) -> bool:
        good = bool(ok) and all(r.outcome == "proven" for r in proofs)
        out.append((name, bool(ok), detail, tuple(proofs)))
        if fail_fast and not good:
            raise _FirstFailure
        return good

    try:
        _recheck(section, vehicle, gains, inner, tilt_limit_deg, xi0_m, add, cache or _no_cache, thorough)
    except _FirstFailure:
        pass
    return out


def _same_json(a: Any, b: Any) -> bool:
    """Equal JSON values, floats within a relative 1e-9 (the allowance and the margin are recomputed floats)."""
    if isinstance(b, float) and not isinstance(a, bool) and isinstance(a, (int, float)):
        return abs(float(a) - b) <= 1e-9 * max(abs(b), 1e-300)
    return a == b


#: The stated ``box_proof`` keys.
BOX_PROOF_KEYS = frozenset({"outcome", "rho", "cells", "initial_cells", "refined", "depth", "max_allowance",
                            "min_margin", "enclosure", "method", "failed_cell"})


def _box_proof_row(section: Mapping[str, Any], vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains,
                   tilt_limit_deg: float, rate: float, box: ParameterBox, grid_n: int, P_affine: Any,
                   grid_fam: Any, grid_rho: float, design: list[Any], add: Callable[..., bool], cache: Cache,
                   thorough: bool, delay: int = 0) -> None:
    """The row ``box cells``: the stated ``box_proof`` (if any) checked for form, and with ``thorough`` re-proven."""
    stated = section.get("box_proof")
    rhos = allowed_box_rhos(grid_rho)
    rho = rhos[0]
    if stated is None and not thorough:
        return
    form_ok = True
    if stated is not None:
        claimed = stated.get("rho") if isinstance(stated, Mapping) else None
        rho = next((r for r in rhos if _close(claimed, r, 1e-12)), rho)
        form_ok = (isinstance(stated, Mapping) and set(stated) == BOX_PROOF_KEYS and stated.get("outcome") == "proven"
                   and any(_close(claimed, r, 1e-12) for r in rhos) and stated.get("enclosure") == ENCLOSURE
                   and stated.get("method") == BOX_PROOF_METHOD
                   and stated.get("failed_cell") is None
                   and stated.get("initial_cells") == (grid_n - 1) ** int(np.sum(box.bounds()[1] > box.bounds()[0])))
        if not thorough:
            add("box cells", form_ok, f"stated: {stated.get('cells') if isinstance(stated, Mapping) else None} cells "
                                      f"proven at rho {rho:.10g}; form checked (the cells are re-proven by --thorough)")
            return
    def evaluate(points: np.ndarray) -> np.ndarray:
        return family_cached(vehicle, gains, inner, points, tilt_limit_deg, rate, delay).A_d

    got = cache("cascade.box_proof", design + [rho], lambda: box_proof(evaluate, box, grid_n, P_affine, rho,
                                                                       known_points=grid_fam.points,
                                                                       known_A=grid_fam.A_d))
    # every stated number is the recomputed one (the refinement is deterministic: its cuts are decided on
    # curvatures rounded to six digits)
    same = stated is None or (form_ok and all(_same_json(stated.get(k), v) for k, v in got.to_json().items()))
    detail = (f"{got.cells} cells ({got.initial_cells} + {got.refined} cut, depth {got.depth}) at rho {rho:.10g} "
              f"(decay {-math.log(rho) / control_period(rate):.4g} 1/s); stated "
              f"{stated.get('cells') if isinstance(stated, Mapping) else 'nothing'}; enclosure of A_d estimated "
              f"(corner interpolation, see box_proof.enclosure)")
    add("box cells", same, detail, [got.row()])


def _design_inputs(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, tilt_limit_deg: float,
                   rate: float, box: Any, grid_n: int, delay: int = 0) -> list[Any]:
    """What every rebuilt matrix of a section depends on, as JSON (the first inputs of each cached row)."""
    from dataclasses import asdict

    return [vehicle.as_dict(), type(gains).__name__, asdict(gains), asdict(inner), float(tilt_limit_deg),
            float(rate), box, int(grid_n), int(delay)]


def stated_delay(section: Mapping[str, Any]) -> int | None:
    """The section's measurement delay [samples] (0 when it states none: written before the delay line), or
    ``None`` when it is not a whole number ``>= 0``.

    Parameters
    ----------
    section
        A ``cascade`` section.
    """
    d = section.get("delay_samples", 0)
    return d if isinstance(d, int) and not isinstance(d, bool) and d >= 0 else None


def _recheck(section: Mapping[str, Any], vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains,
             tilt_limit_deg: float, xi0_m: Sequence[float], add: Callable[..., bool], cache: Cache,
             thorough: bool = False) -> None:
    """The rows of :func:`check_cascade_section`, each handed to ``add(name, ok, detail)``."""
    delay = stated_delay(section) if isinstance(section, Mapping) else 0

    need = ("rate_hz", "controller", "attitude_loop", "model", "box", "monte_carlo_default_box",
            "covers_monte_carlo_default", "lyapunov", "grid", "region_of_attraction", "margins", "matrices",
            "decay_rate_1_s", "start_certified")
    missing = [k for k in need if not isinstance(section, Mapping) or k not in section]
    if delay is None:  # stated, but not a number of samples: the loop it claims cannot be rebuilt
        missing.append("delay_samples (a whole number >= 0)")
    if not add("section keys", not missing, f"missing {missing}" if missing else
               "all present" + (f"; measurement delay line of {delay} samples" if delay else "")):
        return
    expected = subsystems(state_names("full", gains.controller, delay))
    try:
        rate = float(section["rate_hz"])
        T = control_period(rate)
        box = ParameterBox.from_json(section["box"])
        mc = ParameterBox.from_json(section["monte_carlo_default_box"])
        grid_n = checked_grid_size(section["grid"].get("points_per_axis", CASCADE_GRID_POINTS_PER_AXIS))
    except (CascadeError, TypeError, ValueError, AttributeError) as exc:
        add("rate and box", False, str(exc))
        return
    add("controller variant", section["controller"] == "discrete" and section["attitude_loop"] == "continuous"
        and section["model"] == model_text(gains.law, delay),
        f"{section['controller']}, attitude {section['attitude_loop']}")
    add("Monte Carlo default box", mc == ParameterBox.monte_carlo_default(), str(mc.to_json()))
    try:
        coverage = LYAPUNOV_COVERAGE if "box_proof" in section else LYAPUNOV_COVERAGE_GRID_ONLY
        texts = (section["lyapunov"]["form"] == LYAPUNOV_FORM and section["lyapunov"]["coverage"] == coverage
                 and section["region_of_attraction"]["note"] == roa_note(gains.law, delay)
                 and section["margins"]["points"] == MARGIN_POINTS and section["margins"]["model"] == margin_model(delay)
                 and all(list(section["lyapunov"]["subsystems"][n]["states"]) == list(expected[n])
                         for n in SUBSYSTEMS))
    except (KeyError, TypeError):
        texts = False
    add("stated method texts and subsystem states", texts, "form, coverage, notes, states")
    add("covers_monte_carlo_default", section["covers_monte_carlo_default"] is box.contains(mc),
        f"stated {section['covers_monte_carlo_default']}, box contains it: {box.contains(mc)}")
    roa = section["region_of_attraction"]
    L = tilt_accel_limit(vehicle, box, tilt_limit_deg)
    add("tilt limit and u0", _close(roa.get("tilt_limit_deg"), tilt_limit_deg) and _close(roa.get("u0_m_s2"), L),
        f"u0 = {L:.6g} m/s^2 at {tilt_limit_deg:g} deg")
    lyap_s = section["lyapunov"]
    try:
        subs = lyap_s["subsystems"]
        dims = {name: tuple(POINT_NAMES.index(d) for d in subs[name]["dims"]) for name in SUBSYSTEMS}
        Pk = {name: np.asarray(subs[name]["P"], float) for name in SUBSYSTEMS}
        rhos = {name: float(subs[name]["rho"]) for name in SUBSYSTEMS}
    except (KeyError, TypeError, ValueError) as exc:
        add("lyapunov block", False, f"unreadable ({exc})")
        return
    # ---- rebuild every matrix in one batched call: nominal, relevance probes, LMI points, grid
    probes = relevance_points(box)
    pts = {name: grid_subset(box, dims[name], LMI_POINTS_PER_AXIS) for name in SUBSYSTEMS}
    allp = np.vstack([np.ones((1, 6))] + list(pts.values()) + [box.grid(grid_n), probes])
    try:
        big = family_cached(vehicle, gains, inner, allp, tilt_limit_deg, rate, delay)
    except CascadeError as exc:
        add("rebuild", False, str(exc))
        return
    n_cert = 1 + sum(p.shape[0] for p in pts.values()) + box.grid(grid_n).shape[0]
    big.spectral_radius  # noqa: B018  once per rebuilt family (it is cached): every check below shares it
    fam = take_points(big, np.arange(n_cert))
    add("relevant coordinates", relevance_consistent(take_points(big, np.arange(n_cert, len(big))), box, dims),
        str({k: subs[k]["dims"] for k in SUBSYSTEMS}))
    mats = section["matrices"]
    nom = take_points(fam, np.arange(1))
    ok = (list(mats.get("state_names", [])) == list(fam.state_names) and _close(mats.get("A_d"), nom.A_d[0])
          and _close(mats.get("Phi"), nom.Phi[0]) and _close(mats.get("Gamma_d"), nom.Gam[0])
          and _close(mats.get("A_kd"), fam.A_kd) and _close(mats.get("B_kd"), fam.B_kd)
          and _close(mats.get("C_k"), fam.C_k) and _close(mats.get("D_k"), fam.D_k))
    aw = anti_windup_matrix(nom)  # stated iff the law has an anti-windup
    ok = ok and set(aw) == {k for k in mats if k == "E_anti_windup"} and all(_close(mats[k], v) for k, v in aw.items())
    add("nominal matrices rebuilt", ok, "A_d, Phi, Gamma_d, A_kd, B_kd, C_k, D_k" + (", E_anti_windup" if aw else "")
        + " vs the design")
    cpl = coupling(nom)
    add("subsystems decoupled", cpl <= COUPLING_TOL and _close(lyap_s.get("coupling"), cpl, 1e-6),
        f"coupling {cpl:.3g} (stated {lyap_s.get('coupling')})")
    lyap: dict[str, RobustLyapunov] = {}
    loops = block_loops(fam, box, pts, dims)
    k = 1 + sum(p.shape[0] for p in pts.values())
    for name in SUBSYSTEMS:
        A, th = loops[name]
        m, q = A.shape[0], th.shape[1]
        good = Pk[name].shape == (q + 1, len(expected[name]), len(expected[name]))
        detail, proofs = "bad P shape", []
        if good:
            wm = witness_margins(Pk[name], A, th)
            sr = float(np.max(np.abs(np.linalg.eigvals(A))))
            rho = rhos[name]
            # the stated rho is the numpy contraction of the stated P at the LMI points (best_decay,
            # reach_lyapunov), equal within its rounding bound: another witness P, even a valid one, is not the
            # one signed; rho < 1 and P > 0 each hold with a margin above rounding (WitnessMargins.ok)
            tol = max(1e-9, wm.rho_bound) if math.isfinite(wm.rho_bound) else 1e-9
            stated_margins = {key: subs[name].get(key) for key in margin_fields(wm)}
            proofs = cache("cascade.lyapunov_proofs", [Pk[name].tolist(), A.tolist(), th.tolist(), rho],
                           lambda: lyapunov_point_proofs(Pk[name], A, th, rho))
            good = (wm.rho < 1.0 and abs(wm.rho - rho) <= tol and m == subs[name]["lmi_points"]
                    and _close(subs[name]["spectral_radius"], sr)
                    and _close(subs[name]["decay_rate_1_s"], -math.log(rho) / T)
                    and all(_stated_margin_ok(key, stated_margins[key], v) for key, v in margin_fields(wm).items()))
            detail = (f"{m} points, contraction {wm.rho:.10f} = rho {rho:.10f} < 1 by {1 - wm.rho:.3g} "
                      f"(rounding bound {wm.rho_bound:.2g}); min eig scaled P {wm.definite:.3g}")
            lyap[name] = RobustLyapunov(P=Pk[name], rho=rho, rho_vertices=wm.rho_all, spectral_radius=sr, T=T,
                                        decay_rate_1_s=-math.log(rho) / T, min_eig_P=wm.min_eig_ratio,
                                        status="stored", ok=good)
        add(f"Lyapunov LMI [{name}]", good, detail, proofs)
    if len(lyap) != len(SUBSYSTEMS):
        return
    add("rho and decay rate", _close(lyap_s.get("rho"), max(rhos.values())) and _close(lyap_s.get("period_s"), T)
        and _close(section["decay_rate_1_s"], min(l.decay_rate_1_s for l in lyap.values())),
        f"decay {min(l.decay_rate_1_s for l in lyap.values()):.6g} 1/s")
    grid_fam = take_points(fam, np.arange(k, n_cert))
    # the Lyapunov blocks above are functions of the design and the stated lyapunov section alone
    design = _design_inputs(vehicle, gains, inner, tilt_limit_deg, rate, section["box"], grid_n, delay) + [lyap_s]
    P_affine = full_affine_P(Pk, dims, fam.state_names, fam.frame)
    gc = None
    try:
        gc = cache("cascade.grid_check", design, lambda: grid_check(
            grid_fam, assemble_P(lyap, dims, box, grid_fam.points, fam.state_names, fam.frame), grid_n))
        grid_proof = cache("cascade.grid_proof", design, lambda: grid_point_proofs(
            P_affine, box, grid_fam.points, grid_fam.A_d, float(gc.worst_rho)))
        g = section["grid"]
        ok = (gc.worst_rho < 1.0 and g.get("size") == gc.size and g.get("ok") is True
              and _same_worst(g, gc, grid_fam.points)
              and _stated_margin_ok("rounding_bound", g.get("rounding_bound"), gc.rounding_bound)
              # (1 - rho) / bound is known to within the bound's own share of it: 1 (rho is, to the bound)
              and _is_number(g.get("margin_over_bound"))
              and abs(float(g["margin_over_bound"]) - gc.margin_over_bound) <= 1.0 + BOUND_RTOL * gc.margin_over_bound)
        add("grid check", ok, f"{gc.size} points, worst rho {gc.worst_rho:.8f}, worst spectral radius "
                              f"{gc.worst_spectral_radius:.8f}", [grid_proof])
    except (KeyError, TypeError, ValueError, np.linalg.LinAlgError) as exc:
        add("grid check", False, f"unreadable or not positive definite ({exc})")
    if gc is None:
        if "box_proof" in section or thorough:
            add("box cells", False, "not re-proven: the grid check could not run")
    else:
        _box_proof_row(section, vehicle, gains, inner, tilt_limit_deg, rate, box, grid_n, P_affine, grid_fam,
                       float(gc.worst_rho), design, add, cache, thorough, delay)
    try:
        lz_lmi, lz_grid = cache("cascade.linear_zone", design, lambda: (linear_zone_reach(lyap, dims, box, fam, L),
                                                                         linear_zone_reach(lyap, dims, box, grid_fam, L)))
        method = roa.get("method")
        roa_proofs: list[ProofRow] = []
        ok = _close(roa.get("linear_zone_reach_lmi_points_m"), lz_lmi) and _close(roa.get("linear_zone_reach_grid_m"),
                                                                                  lz_grid)
        reach, detail = min(lz_lmi, lz_grid), f"linear zone {min(lz_lmi, lz_grid):.6g} m"
        if method == "linear_zone":
            ok = ok and _close(roa.get("max_displacement_m"), reach) and "lure" not in roa
        elif method == "lure":  # solved for the law's start (region.start_vector: controller at take-over, delay line full)
            start, lmi = 1, {}
            for name in SUBSYSTEMS:  # each horizontal axis's LMI points, as the family is stacked above
                if name in HORIZONTAL:
                    lmi[name] = take_points(fam, np.arange(start, start + pts[name].shape[0]))
                start += pts[name].shape[0]
            lure_ok, lure_detail, lure_reach = cache("cascade.lure", design + [roa["lure"]],
                                                     lambda: check_lure_block(roa["lure"], dims, box, lmi, grid_fam,
                                                                              lyap))
            roa_proofs = cache("cascade.lure_proofs", design + [roa["lure"]], lambda: lure_proofs(
                LureRegion.from_json(roa["lure"], dims, axis_states(grid_fam)), box, lmi, grid_fam, lyap, dims))
            # the stated reach is the recomputed one (never larger), and reaches beyond the linear zone
            stated = roa.get("max_displacement_m")
            ok = (ok and lure_ok and _is_number(stated) and lure_reach * (1 - 2e-9) <= stated <= lure_reach
                  and lure_reach > reach)
            reach, detail = lure_reach, lure_detail
        else:
            ok = False
        add("region of attraction", ok, f"{method}: stated reach {roa.get('max_displacement_m')} m; {detail}",
            roa_proofs)
        r0 = math.hypot(*(float(v) for v in xi0_m))
        add("start certified", section["start_certified"] is bool(r0 <= float(roa["max_displacement_m"])),
            f"start {r0:.6g} m, reach {roa.get('max_displacement_m')} m: stated {section['start_certified']}")
    except (KeyError, TypeError, ValueError, np.linalg.LinAlgError) as exc:
        add("region of attraction", False, f"unreadable ({exc})")
    # ---- margins at the stated worst points (the most expensive check: last)
    try:

        worst = section["margins"]["worst"]
        wpts = []
        for bp, w in worst.items():
            for key in ("gm_db", "gm_lower_db", "pm_deg"):
                wpts.append((bp, key, w[key], [float(w[key + "_point"][n]) for n in POINT_NAMES]))
        uniq = sorted({tuple(p[3]) for p in wpts})

        def margins_at_points() -> dict:
            mf = family_cached(vehicle, gains, inner, np.array(uniq, float), tilt_limit_deg, rate)
            return {u: fast_cascade_margins(mf.cascade_at(i), rate) for i, u in enumerate(uniq)}

        got = cache("cascade.margins", _design_inputs(vehicle, gains, inner, tilt_limit_deg, rate, None, 0)
                    + [[list(u) for u in uniq]], margins_at_points)
        mdims = set(dims["x"]) | set(dims["y"])
        lo, hi = box.bounds()
        ok = all(_close(float(v), getattr(got[tuple(p)][bp], key), 1e-6) for bp, key, v, p in wpts) and all(
            w["stable"] is True for w in worst.values()) and all(got[tuple(p)][bp].stable for bp, _, _, p in wpts) and all(
            all((p[j] == lo[j] or p[j] == hi[j]) if j in mdims else p[j] == 1.0 for j in range(6)) for *_, p in wpts)
        add("margins at the stated worst vertices", ok, f"{len(uniq)} vertices recomputed")
    except (KeyError, TypeError, ValueError, CascadeError) as exc:
        add("margins at the stated worst vertices", False, f"unreadable ({exc})")
