"""The schema-2 ``cascade`` section of a certificate: the box, the Lyapunov blocks, the grid, the region, the margins.

:func:`cascade_section` certifies a box (the Monte Carlo default box, else its scale halved until it certifies:
:func:`widest_box`), states each subsystem's ``P(θ)`` with its margins, the grid check on the coupled loop,
the region of attraction under the tilt limit (:mod:`nniquad.analysis.cascade.region`) and the classical margins at
the box's vertices.  :mod:`nniquad.analysis.cascade.recheck` re-checks every stated number.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from nniquad.analysis.cascade.box import (
    POINT_NAMES,
    ParameterBox,
    grid_subset,
    normalised_coordinates,
    tilt_accel_limit,
)
from nniquad.analysis.cascade.box_proof import full_affine_P, prove_box
from nniquad.analysis.cascade.family import (
    SUBSYSTEMS,
    CascadeFamily,
    anti_windup_rows,
    coupling,
    relevant_coordinates,
    sampled_family,
    subsystem_of,
    subsystems,
    take_points,
)
from nniquad.analysis.cascade.lyapunov import (
    WitnessMargins,
    assemble_P,
    block_loops,
    checked_grid_size,
    grid_check,
    mirror_blocks,
    mirrored_blocks,
    reach_lyapunov,
    robust_lyapunov,
    witness_margins,
)
from nniquad.analysis.cascade.region import linear_zone_reach, roa_note, start_vector
from nniquad.analysis.cascade.region_lmi import lure_section
from nniquad.analysis.fast_margins import fast_cascade_margins
from nniquad.config import (
    CASCADE_GRID_POINTS_PER_AXIS,
    CASCADE_REACH_DECAY_FRACTION,
    CASCADE_SMALLEST_SCALE,
    CASCADE_WIDEST_SCALE_MAX,
    CASCADE_WIDEST_STEPS,
    CONTROL_RATE_HZ,
    XI0_M,
)
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CascadeError, SolverError
from nniquad.laws.base import ControlLaw, GainBlock
from nniquad.model.vehicle import Vehicle

__all__ = ["anti_windup_matrix", "LMI_POINTS_PER_AXIS", "BoxSearch", "widest_box", "cascade_section", "last_timings",
           "model_text", "margin_model"]


#: Points per coordinate of each subsystem's Lyapunov LMI (the vertices and the centre); the numpy grid
#: check uses :data:`nniquad.config.CASCADE_GRID_POINTS_PER_AXIS` (other points than these, but the vertices).
LMI_POINTS_PER_AXIS = 3
#: States of the linearised cascade besides the law's: rigid body 12, altitude integrator 1, rotors 4.
CASCADE_STATES_BESIDES_THE_LAW = 17


def model_text(law: ControlLaw, delay_samples: int = 0) -> str:
    """The section's stated model, naming the states and the law's controller (the NNI law: 19 states, "NNI").

    Parameters
    ----------
    law
        The certified law.
    delay_samples
        Length of the measurement delay line [samples] (2 states per sample).
    """
    n = CASCADE_STATES_BESIDES_THE_LAW + len(law.sim_state_names) + 2 * int(delay_samples)
    line = f", measurement delay line of {int(delay_samples)} samples" if delay_samples else ""
    return (f"full (linearised at hover, {n} states: rigid body, altitude PID, yaw, attitude PD, motors, "
            f"{law.controller_label}{line})")


def margin_model(delay_samples: int = 0) -> str:
    """The stated model of the margins (:data:`MARGIN_MODEL`; the measurement delay is not in it).

    Parameters
    ----------
    delay_samples
        The section's measurement delay [samples].
    """
    return MARGIN_MODEL + (", without the measurement delay (the Lyapunov blocks include it)" if delay_samples
                           else "")
LYAPUNOV_FORM = "P(θ) = P0 + Σ θ_j P_j per decoupled subsystem, θ ∈ [-1, 1] the log factors normalised on the box"
LYAPUNOV_COVERAGE = ("the LMI holds at the LMI points (grid of 3 per coordinate: vertices, centre, mid-faces); "
                     "the contraction is proven at the grid points, and over every cell between them by box_proof "
                     "(P(theta) exact, the range of A_d over a cell estimated: box_proof.enclosure)")
#: The coverage stated by certificates issued before the box proof (no ``box_proof``: the grid points only).
LYAPUNOV_COVERAGE_GRID_ONLY = ("the LMI holds at the LMI points (grid of 3 per coordinate: vertices, centre, "
                               "mid-faces); the interior is checked with numpy at the grid points only")
MARGIN_POINTS = "vertices of the box in the coordinates that reach the horizontal axes"
MARGIN_MODEL = "Padé (order 2) model of the sampling, continuous time (nniquad.analysis.fast_margins)"
#: Wall-clock seconds of the parts of the last :func:`cascade_section` (not stored in the section: not checkable).
last_timings: dict[str, float] = {}


def _certify_box(vehicle, gains, inner, box, *, tilt_limit_deg, rate_hz, dims, grid_n, delay_samples=0):
    """The subsystem LMIs at the LMI points and the full grid check; raises SolverError when not certified.

    The horizontal axes get two candidates: the fastest decay (:func:`robust_lyapunov`) and the widest
    linear-zone reach at a slightly slower one (:func:`reach_lyapunov`); the widest that passes the grid
    check is kept.
    """
    pts = {name: grid_subset(box, dims[name], LMI_POINTS_PER_AXIS) for name in SUBSYSTEMS}
    allp = np.vstack([np.ones((1, 6))] + list(pts.values()) + [box.grid(grid_n)])
    fam = sampled_family(vehicle, gains, inner, allp, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                         delay_samples=delay_samples)
    L = tilt_accel_limit(vehicle, box, tilt_limit_deg)
    lyap, wide, k = {}, {}, 1
    blocks: dict[str, tuple] = {}
    for name in SUBSYSTEMS:
        m = pts[name].shape[0]
        A, _, _, K = subsystem_of(fam, name)
        A, th = A[k:k + m], normalised_coordinates(box, pts[name], dims[name])
        blocks[name] = (A, K, th)
        d = mirror_blocks(blocks["x"], blocks[name]) if name == "y" else None
        # y is x in mirrored coordinates: the mirrored answers, re-checked on y's own loops, else solved
        mirrored = mirrored_blocks(lyap["x"], d, A, th) if d is not None else None
        lyap[name] = mirrored or robust_lyapunov(A, fam.T, theta=th)
        if K is not None:  # a horizontal axis: also the widest reach at a slightly slower decay
            rho = math.exp(-CASCADE_REACH_DECAY_FRACTION * lyap[name].decay_rate_1_s * fam.T)
            wide[name] = (mirrored_blocks(wide["x"], d, A, th) if mirrored is not None and wide["x"] is not None
                          else None) or reach_lyapunov(A, fam.T, K, L, rho, theta=th,
                                                       # the delay line starts full: its start is not e_0 (without
                                                       # a delay the search stays the one of the issued certificates)
                                                       start=start_vector(fam, name) if delay_samples else None)
        k += m
    grid_fam = take_points(fam, np.arange(k, len(fam)))
    lmi_fam = take_points(fam, np.arange(1, k))
    candidates = [lyap]
    if all(wide.get(a) is not None for a in ("x", "y")):
        widened = {**lyap, **wide}
        if linear_zone_reach(widened, dims, box, lmi_fam, L) > linear_zone_reach(lyap, dims, box, lmi_fam, L):
            candidates.insert(0, widened)
    for cand in candidates:  # the widest reach whose grid check passes, else the fastest decay
        gc = grid_check(grid_fam, assemble_P(cand, dims, box, grid_fam.points, fam.state_names, fam.frame), grid_n)
        if gc.ok:
            return fam, pts, cand, grid_fam, gc
    raise SolverError(f"cascade grid check fails: contraction {gc.worst_rho:.6g} at {gc.worst_point}")


@dataclass(frozen=True)
class BoxSearch:
    """The result of :func:`widest_box`: the widest scale certified and the certificate's parts there.

    Attributes
    ----------
    scale
        Widest scale ``s`` of the base box certified (log space about nominal).
    first_failed_scale
        Smallest scale tried that failed (``inf`` when ``s_max`` certified).
    steps
        What was tried, in order: ``(scale, certified)``.
    parts
        :func:`_certify_box`'s answer at ``scale`` (family, LMI points, Lyapunov, grid family, grid check).
    dims
        Relevant coordinates of each subsystem on the certified box.
    """

    scale: float
    first_failed_scale: float
    steps: tuple[tuple[float, bool], ...]
    parts: tuple
    dims: Mapping[str, tuple[int, ...]]


def widest_box(vehicle, gains, inner, base: ParameterBox, *, tilt_limit_deg, rate_hz,
               grid_n: int = CASCADE_GRID_POINTS_PER_AXIS, widest: bool = False,
               steps: int = CASCADE_WIDEST_STEPS, s_max: float = CASCADE_WIDEST_SCALE_MAX,
               s_min: float = CASCADE_SMALLEST_SCALE, delay_samples: int = 0) -> BoxSearch:
    """The widest scale ``s`` with ``base.scaled(s)`` certified, with the certificate's own grid check.

    Certified means what the certificate states: every subsystem LMI feasible at
    its LMI points (relevant coordinates of the scaled box) and the numpy grid
    check with ``grid_n`` points per coordinate passing.  The scale starts at 1
    and is halved until it certifies (down to ``s_min``).  With ``widest``, a
    certified 1 is followed by ``s_max``, and ``steps`` bisection steps then
    narrow the gap between the widest certified and the narrowest failed scale.

    Parameters
    ----------
    vehicle, gains, inner
        The design.
    base
        The box scaled (the Monte Carlo default box).
    tilt_limit_deg, rate_hz
        Tilt limit [deg] and control rate [Hz].
    grid_n
        Points per coordinate of the grid check.
    widest
        Search above the first certified scale too.
    steps, s_max, s_min
        Bisection steps, largest and smallest scale tried.
    delay_samples
        Measurement delay [samples] (:func:`nniquad.analysis.cascade.family.with_delay_line`).

    Returns
    -------
    BoxSearch

    Raises
    ------
    SolverError
        Not even ``base.scaled(s_min)`` certifies.
    """
    tried: list[tuple[float, bool]] = []
    found: dict[float, tuple] = {}

    def ok(s: float) -> bool:
        box = base.scaled(s)
        try:
            dims = relevant_coordinates(vehicle, gains, inner, box, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                                        delay_samples=delay_samples)
            found[s] = (_certify_box(vehicle, gains, inner, box, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                                     dims=dims, grid_n=grid_n, delay_samples=delay_samples), dims)
        except (SolverError, CascadeError):
            pass
        tried.append((s, s in found))
        return s in found

    s, bad = 1.0, math.inf
    while not ok(s):
        bad = s
        if s <= s_min:
            raise SolverError(f"the cascade is not certified even on the Monte Carlo box scaled by {s_min:g} "
                              f"(log space about the nominal point)")
        s = max(s / 2, s_min)
    if widest:
        if bad == math.inf and s_max > s:
            if ok(s_max):
                s = s_max
            else:
                bad = s_max
        for _ in range(steps if math.isfinite(bad) else 0):
            mid = 0.5 * (s + bad)
            s, bad = (mid, bad) if ok(mid) else (s, mid)
    parts, dims = found[s]
    return BoxSearch(scale=s, first_failed_scale=bad, steps=tuple(tried), parts=parts, dims=dims)


def _vertex_margins(fam: CascadeFamily, rate_hz: float, delay_samples: int = 0) -> dict[str, Any]:
    """Worst fast margins (:mod:`nniquad.analysis.fast_margins`) over the points of ``fam``."""

    worst: dict[str, dict[str, Any]] = {}
    better = {"gm_db": lambda a, b: a < b, "gm_lower_db": lambda a, b: a > b, "pm_deg": lambda a, b: a < b}
    for i in range(len(fam)):
        pt = dict(zip(POINT_NAMES, (float(v) for v in fam.points[i])))
        for bp, m in fast_cascade_margins(fam.cascade_at(i), rate_hz).items():
            w = worst.setdefault(bp, {"stable": True})
            w["stable"] = bool(w["stable"] and m.stable)
            for k, cmp in better.items():
                v = getattr(m, k)
                if k not in w or cmp(v, w[k]):
                    w[k], w[k + "_point"] = v, pt
    for w in worst.values():
        for k, v in list(w.items()):
            if isinstance(v, float) and not math.isfinite(v):
                w[k] = str(v)
    return {"points": MARGIN_POINTS, "model": margin_model(delay_samples), "worst": worst}


_SECTIONS: dict[tuple, dict[str, Any]] = {}


def cascade_section(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, *, tilt_limit_deg: float,
                    rate_hz: float = CONTROL_RATE_HZ, box: ParameterBox | None = None,
                    widest: bool = False, grid_points_per_axis: int = CASCADE_GRID_POINTS_PER_AXIS,
                    xi0_m: Sequence[float] = XI0_M, delay_samples: int = 0) -> dict[str, Any]:
    """The schema-2 ``cascade`` section of a certificate (module docstring for the maths).

    A section is a pure function of its inputs, so one computed earlier in the
    same process for the same inputs is returned again (a deep copy): the
    solves take about 15-40 s, and a test session builds the same design several times.
    """
    import copy

    # the grid size is checked before the lookup: int(3.0) == 3 would otherwise find a section of a valid size
    # computed earlier in this process, and the one rule verify applies would depend on what ran before
    key = (vehicle, gains, inner, float(tilt_limit_deg), float(rate_hz), box, bool(widest),
           checked_grid_size(grid_points_per_axis), tuple(float(v) for v in xi0_m), int(delay_samples))
    if key not in _SECTIONS:
        _SECTIONS[key] = _cascade_section(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                                          box=box, widest=widest, grid_points_per_axis=grid_points_per_axis,
                                          xi0_m=xi0_m, delay_samples=delay_samples)
    return copy.deepcopy(_SECTIONS[key])


def _cascade_section(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, *, tilt_limit_deg: float,
                     rate_hz: float = CONTROL_RATE_HZ, box: ParameterBox | None = None,
                     widest: bool = False, grid_points_per_axis: int = CASCADE_GRID_POINTS_PER_AXIS,
                     xi0_m: Sequence[float] = XI0_M, delay_samples: int = 0) -> dict[str, Any]:
    """:func:`cascade_section` without the cache.

    Parameters
    ----------
    vehicle, gains, inner
        The design.
    tilt_limit_deg
        Tilt limit [deg] of the region of attraction.
    rate_hz
        Control rate [Hz].
    box
        The box to certify; ``None``: the Monte Carlo default box if it
        certifies, else its scale halved until it does (:func:`widest_box`).
    widest
        Search the widest scale of the Monte Carlo default box, up to
        :data:`~nniquad.config.CASCADE_WIDEST_SCALE_MAX` (a few more solves of
        the whole box: off by default to keep ``certify`` within its budget).
        With ``box=None`` the widest box is certified; with a given ``box`` it is
        only reported.
    grid_points_per_axis
        Points per coordinate of the numpy grid check (default
        :data:`nniquad.config.CASCADE_GRID_POINTS_PER_AXIS`).
    xi0_m
        The reference start [m]: ``start_certified`` states whether it lies in the certified region.
    delay_samples
        Measurement delay [samples] the loop is certified with: a delay line of that many samples per axis
        between the position and the law (:func:`nniquad.analysis.cascade.family.with_delay_line`); the start
        fills it with the start position (:func:`nniquad.analysis.cascade.region.start_vector`, the start of both
        regions); the margins are without it.

    Raises
    ------
    SolverError
        The box (or, with ``box=None``, even the nominal point) is not certified.
    """
    t0 = time.perf_counter()
    mc = ParameterBox.monte_carlo_default()
    grid_n = checked_grid_size(grid_points_per_axis)
    timings: dict[str, float] = {}
    search = None
    if box is None or widest:
        # one search, with the certificate's own grid: the Monte Carlo box, halved until it certifies
        search = widest_box(vehicle, gains, inner, mc, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                            grid_n=grid_n, widest=widest, delay_samples=delay_samples)
    if box is None:
        box = mc.scaled(search.scale) if search.scale != 1.0 else mc
        (fam, pts, lyap, grid_fam, gc), dims = search.parts, search.dims
    else:
        dims = relevant_coordinates(vehicle, gains, inner, box, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz,
                                    delay_samples=delay_samples)
        fam, pts, lyap, grid_fam, gc = _certify_box(vehicle, gains, inner, box, tilt_limit_deg=tilt_limit_deg,
                                                    rate_hz=rate_hz, dims=dims, grid_n=grid_n,
                                                    delay_samples=delay_samples)
    s_ok = search.scale if search is not None else math.nan
    s_bad = search.first_failed_scale if search is not None else math.nan
    T = fam.T
    decay = min(l.decay_rate_1_s for l in lyap.values())
    L = tilt_accel_limit(vehicle, box, tilt_limit_deg)
    timings["box_lyapunov_and_grid_s"] = time.perf_counter() - t0  # the box search included
    lz_lmi = linear_zone_reach(lyap, dims, box, fam, L)
    lz_grid = linear_zone_reach(lyap, dims, box, grid_fam, L)
    # the Lur'e-Postnikov region, kept when it passes every numpy check and reaches further than the linear zone;
    # it is solved for the law's start (region.start_vector: its controller at its take-over state, a delay line
    # full of the start position)
    lure, record = lure_section(fam, pts, lyap, grid_fam, box, dims)
    reach = min(lz_lmi, lz_grid)
    roa_block: dict[str, Any] = {"u0_m_s2": L, "tilt_limit_deg": float(tilt_limit_deg), "method": "linear_zone"}
    if lure is not None and min(lure["check_lmi_points"]["reach_m"], lure["check_grid"]["reach_m"]) > reach:
        # stated a hair below the reach checked, so that another machine's rounding never finds it larger
        reach = min(lure["check_lmi_points"]["reach_m"], lure["check_grid"]["reach_m"]) * (1.0 - 1e-9)
        roa_block.update(method="lure", lure=lure)
    roa_block.update({"max_displacement_m": reach, "linear_zone_reach_lmi_points_m": lz_lmi,
                      "linear_zone_reach_grid_m": lz_grid, "note": roa_note(gains.law, delay_samples),
                      "lure_search": record})  # a record (nniquad.certificates.verify.RECORD_FIELDS)
    timings["roa_s"] = time.perf_counter() - t0 - sum(timings.values())
    mdims = tuple(sorted(set(dims["x"]) | set(dims["y"])))
    margins = _vertex_margins(sampled_family(vehicle, gains, inner, grid_subset(box, mdims, 2),
                                             tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz), rate_hz,
                              delay_samples)
    nom = take_points(fam, np.arange(1))
    loops = block_loops(fam, box, pts, dims)
    timings["margins_s"] = time.perf_counter() - t0 - sum(timings.values())
    proof = prove_box(lambda p: sampled_family(vehicle, gains, inner, p, tilt_limit_deg=tilt_limit_deg,
                                               rate_hz=rate_hz, delay_samples=delay_samples).A_d,
                      box, grid_n, full_affine_P({n: l.P for n, l in lyap.items()}, dims, fam.state_names, fam.frame),
                      float(gc.worst_rho), known_points=grid_fam.points, known_A=grid_fam.A_d)
    timings["box_proof_s"] = time.perf_counter() - t0 - sum(timings.values())
    section = {
        "rate_hz": float(rate_hz), "controller": "discrete", "attitude_loop": "continuous",
        "model": model_text(gains.law, delay_samples), "delay_samples": int(delay_samples),
        "box": box.to_json(), "monte_carlo_default_box": mc.to_json(),
        "covers_monte_carlo_default": bool(box.contains(mc)),
        # how the box was found: a record (nniquad.certificates.verify.RECORD_FIELDS), not a claim: verify
        # re-checks the certified box, and does not re-run the search
        "box_search": None if search is None else {
            "base": "monte_carlo_default_box", "scaling": "log space about nominal: [lo^s, hi^s]",
            "method": "bisection" if widest else "halving", "grid_points_per_axis": grid_n,
            "widest_certified_scale": s_ok,
            "first_failed_scale": str(s_bad) if not math.isfinite(s_bad) else s_bad,
            "scales_tried": [{"scale": sc, "certified": ok} for sc, ok in search.steps]},
        "lyapunov": {
            "form": LYAPUNOV_FORM, "coverage": LYAPUNOV_COVERAGE,
            "period_s": T, "rho": max(l.rho for l in lyap.values()), "coupling": coupling(nom),
            "subsystems": {name: {"states": list(subsystems(fam.state_names)[name]),
                                  "dims": [POINT_NAMES[j] for j in dims[name]],
                                  "lmi_points": int(pts[name].shape[0]), "rho": l.rho,
                                  "decay_rate_1_s": l.decay_rate_1_s, "spectral_radius": l.spectral_radius,
                                  **margin_fields(witness_margins(l.P, *loops[name])),
                                  "P": l.P.tolist()} for name, l in lyap.items()},
        },
        "grid": gc.to_json(),
        "box_proof": proof.to_json(),
        "region_of_attraction": roa_block,
        "margins": margins,
        "matrices": {"state_names": list(fam.state_names), "A_d": nom.A_d[0].tolist(), "Phi": nom.Phi[0].tolist(),
                     "Gamma_d": nom.Gam[0].tolist(), "A_kd": fam.A_kd.tolist(), "B_kd": fam.B_kd.tolist(),
                     "C_k": fam.C_k.tolist(), "D_k": fam.D_k.tolist(),
                     **anti_windup_matrix(fam)},
        "decay_rate_1_s": decay,
        "start_certified": bool(math.hypot(*(float(v) for v in xi0_m)) <= reach),
    }
    last_timings.clear()
    last_timings.update(timings, total_s=time.perf_counter() - t0)
    return section


def anti_windup_matrix(fam: CascadeFamily) -> dict[str, list]:
    """``{"E_anti_windup": E}`` of the controller states (:func:`nniquad.analysis.cascade.family.anti_windup_rows`:
    the sampled loop is ``x⁺ = A0 x + B sat(K x)`` with ``A0 + E K`` and ``B = Γ - E``), or ``{}`` for a law
    without anti-windup (the section then states no such matrix)."""
    ctx = fam.context
    n_k = fam.A_k.shape[0]
    end = len(fam.state_names) - 2 * fam.delay_samples  # the delay line's states follow the controller's
    E = anti_windup_rows(ctx["gains"], ctx["vehicle"].m, fam.state_names[end - n_k:end], fam.T)
    return {"E_anti_windup": E.tolist()} if np.any(E) else {}


def margin_fields(wm: WitnessMargins) -> dict[str, float]:
    """A subsystem's stated rounding margins: ``1 - rho`` must exceed ``rho_rounding_bound``, and the smallest
    eigenvalue of the scaled ``P(θ)`` at the cube's corners must exceed ``min_eig_bound``."""
    return {"rho_rounding_bound": wm.rho_bound, "min_eig_scaled": wm.definite, "min_eig_bound": wm.definite_bound}
