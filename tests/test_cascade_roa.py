"""The cascade's region of attraction under the norm tilt limit (nniquad.analysis.cascade.region, roa_lmi).

Each test compares the stated region against something independent of its LMI: the saturated sampled loop
simulated step by step (V along it, and where it ends), the closed-form level of a start, a perturbed input
(a lower tilt limit, a wider box, an edited number) that must be refused, and the nonlinear full simulator.
"""

from __future__ import annotations

import copy
import itertools
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from nniquad.analysis.cascade import box_certificate as RC
from nniquad.analysis.cascade import family as RF
from nniquad.analysis.cascade import region as RR
from nniquad.analysis.cascade.box import grid_subset
from tests.test_robust_cascade import BOX, GAINS, INNER, RATE, TILT, V

ROOT = Path(__file__).resolve().parents[1]
COMMITTED = ROOT / "notebooks" / "data" / "full_model_certificate.json"


@pytest.fixture(scope="module")
def section(shared_json):
    # the section of tests/test_robust_cascade.py, built once per session
    return shared_json("robust-cascade-section", lambda: RC.cascade_section(
        V, GAINS, INNER, tilt_limit_deg=TILT, rate_hz=RATE, box=BOX, grid_points_per_axis=2))


def _dims(section):
    return {n: tuple(RC.POINT_NAMES.index(d) for d in section["lyapunov"]["subsystems"][n]["dims"])
            for n in RC.SUBSYSTEMS}


def _region(section):
    return RR.LureRegion.from_json(section["region_of_attraction"]["lure"], _dims(section))


def _failed(sec, xi0=(2.0, -1.5)):
    return [n for n, ok, _ in RC.check_cascade_section(sec, V, GAINS, INNER, tilt_limit_deg=TILT, xi0_m=xi0)
            if not ok]


def _V(region, fam, X):
    """``V`` of the stated region at states ``X`` (one per point of ``fam``, original 19-state coordinates)."""
    Tm, _ = RC.mode_transform(fam.state_names, fam.frame)
    out = np.zeros(len(fam))
    for a, sl in RF.subsystem_blocks().items():
        if a in RR.HORIZONTAL:
            P, _, mu = region.at(BOX, fam.points, a)
            xa = X @ Tm[sl].T
            out += np.einsum("ni,nij,nj->n", xa, P, xa)
    nu = np.linalg.norm(X @ fam.K.T, axis=1) / np.asarray(fam.accel_limit)
    return out + 2.0 * mu * RR.huber(nu)


def test_the_region_reaches_deep_into_the_saturation_and_verifies(section):
    roa = section["region_of_attraction"]
    assert roa["method"] == "lure"
    assert roa["max_displacement_m"] > 20 * roa["linear_zone_reach_grid_m"]
    lure = roa["lure"]
    # commands up to 1/eps times the limit inside the region: far past the linear zone (eps = 1 there)
    assert lure["check_grid"]["eps"] < 0.1
    assert section["start_certified"] is (math.hypot(2.0, -1.5) <= roa["max_displacement_m"])
    assert _failed(section) == []


def test_V_never_increases_along_the_saturated_loop_from_the_boundary(section):
    """The saturated sampled 19-state loop (norm limit at each point's own L), simulated from the certified rim at
    every vertex of the box and in several directions: V never increases, and the loop converges."""
    region = _region(section)
    reach = section["region_of_attraction"]["max_displacement_m"]
    fam = RC.sampled_family(V, GAINS, INNER, BOX.vertices(), tilt_limit_deg=TILT, rate_hz=RATE)
    L = np.asarray(fam.accel_limit)[:, None]
    ix, iy = fam.state_names.index("x"), fam.state_names.index("y")
    for ang in (0.0, 0.9, 2.3, 4.0, 5.5):
        X = np.zeros((len(fam), fam.A_d.shape[1]))
        X[:, ix], X[:, iy] = reach * math.cos(ang), reach * math.sin(ang)
        v = _V(region, fam, X)
        assert np.all(v <= region.level * (1 + 1e-9))  # the rim lies in the region
        v0 = v.copy()
        for _ in range(3000):
            a = X @ fam.K.T
            a = a * np.minimum(1.0, L / np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-300))
            X = np.einsum("nij,nj->ni", fam.A0, X) + np.einsum("nij,nj->ni", fam.B, a)
            v_next = _V(region, fam, X)
            assert np.all(v_next <= v + 1e-12 * v0)
            v = v_next
        assert np.max(np.hypot(X[:, ix], X[:, iy])) < 1e-3 * reach and np.max(v) < 1e-6 * np.max(v0)


def test_a_start_just_outside_the_stated_region_is_not_claimed(section):
    """The stated reach is the level set's, to rounding: a start 1e-6 further out at the binding point has
    ``V > c`` (closed form), and ``start_certified`` must then be false."""
    region = _region(section)
    reach = section["region_of_attraction"]["max_displacement_m"]
    dims = _dims(section)
    pts = np.vstack([grid_subset(BOX, dims["x"], 3), grid_subset(BOX, dims["y"], 3), BOX.grid(2)])  # LMI points and grid
    fam = RC.sampled_family(V, GAINS, INNER, pts, tilt_limit_deg=TILT, rate_hz=RATE)
    levels = []
    for r in (reach * (1 - 1e-6), reach * (1 + 1e-6)):
        worst = np.zeros(len(fam))
        for name in ("x", "y"):
            X = np.zeros((len(fam), fam.A_d.shape[1]))
            X[:, fam.state_names.index(name)] = r
            worst = np.maximum(worst, _V(region, fam, X))
        levels.append(worst)
    inside, outside = levels
    assert np.all(inside <= region.level) and np.max(outside) > region.level
    sec = copy.deepcopy(section)
    assert sec["start_certified"] is True
    assert "start certified" in _failed(sec, xi0=(reach * (1 + 1e-6), 0.0))
    assert "start certified" not in _failed(sec, xi0=(0.0, reach * (1 - 1e-6)))
    sec["start_certified"] = False
    assert "start certified" not in _failed(sec, xi0=(reach * (1 + 1e-6), 0.0))


def test_the_stated_region_fails_its_check_past_its_box_and_saturation(section):
    """The stated matrices, re-checked with numpy where they were not certified: the vertices of a wider box,
    and the certified box with a lower tilt limit, each fail a condition."""
    region = _region(section)
    low = RC.sampled_family(V, GAINS, INNER, BOX.vertices(), tilt_limit_deg=10.0, rate_hz=RATE)
    assert not RR.lure_check(region, BOX, low).ok
    wide = BOX.scaled(3.0)
    fam = RC.sampled_family(V, GAINS, INNER, wide.vertices(), tilt_limit_deg=TILT, rate_hz=RATE)
    assert not RR.lure_check(region, BOX, fam).ok


@pytest.mark.parametrize("path, factor", [
    (("region_of_attraction", "max_displacement_m"), 1.001),
    (("region_of_attraction", "max_displacement_m"), 0.999),
    (("region_of_attraction", "lure", "mu", 0), 1.001),
    (("region_of_attraction", "lure", "mu", 1), 1.1),
    (("region_of_attraction", "lure", "check_grid", "eps"), 1.001),
    (("region_of_attraction", "lure", "check_lmi_points", "eps"), 0.999),
    (("region_of_attraction", "lure", "level"), 1.001),
    (("region_of_attraction", "lure", "rho"), 1 - 1e-9),
    (("region_of_attraction", "lure", "G", "x", 0, 0, 0), 1.001),
    (("region_of_attraction", "lure", "coupled_grid", "decrease"), 1.1),
])
def test_an_edited_number_of_the_region_is_refused(section, path, factor):
    sec = copy.deepcopy(section)
    node = sec
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] *= factor
    assert "region of attraction" in _failed(sec)


def test_an_unsymmetric_or_misshapen_matrix_is_refused(section):
    sec = copy.deepcopy(section)
    sec["region_of_attraction"]["lure"]["P"]["y"][0][0][1] *= 1.001
    assert "region of attraction" in _failed(sec)
    sec = copy.deepcopy(section)
    sec["region_of_attraction"]["lure"]["mu"].append(0.0)
    assert "region of attraction" in _failed(sec)
    sec = copy.deepcopy(section)
    sec["region_of_attraction"]["method"] = "linear_zone"  # a region stated beside another method's reach
    assert "region of attraction" in _failed(sec)


def test_committed_certificate_boundary_converges_in_the_full_simulator():
    """Brute force on the nonlinear full model (rigid body, rotors, inner loops, discrete controller, the true
    tilt limit): the committed certificate's cascade starts on the certified rim, at every vertex of its box,
    in two directions, all converge."""
    import nniquad.study as mc
    from nniquad.study.runs import run_scenarios

    cert = json.loads(COMMITTED.read_text())
    cas = cert["cascade"]
    reach = cas["region_of_attraction"]["max_displacement_m"]
    assert cas["region_of_attraction"]["method"] == "lure" and cas["start_certified"] is True
    ranges, region, _ = mc.within_certificate_ranges(cert)
    setup = mc.study_setup(cert, ranges, region_m=region, horizon_s=15.0)
    s0 = mc.draw_scenario(0, 0, ranges, setup)
    base, box = setup.base, cas["box"]
    scenarios = []
    for k, (fm, fx, fy, fz, fa, ft) in enumerate(itertools.product(
            box["mass_factor"], *[box["inertia_factor"]] * 3, box["attitude_gain_factor"], box["tau_motor_factor"])):
        p = base.plant
        params = s0.sim_params.with_(
            plant={"m": p.m * fm, "Jx": p.Jx * fx, "Jy": p.Jy * fy, "Jz": min(p.Jz * fz, p.Jx * fx + p.Jy * fy),
                   "tau_motor": p.tau_motor * ft},
            inner={"attitude_gain_scale": base.inner.attitude_gain_scale * fa})
        for j, ang in enumerate((0.4 + k, 0.4 + k + math.pi / 2)):
            scenarios.append(replace(s0, index=2 * k + j, params=tuple(float(v) for v in params.vector()),
                                     xi0_m=(reach * math.cos(ang), reach * math.sin(ang))))
    results = run_scenarios(scenarios)
    assert len(results) == 128
    assert all(r.success for r in results), [(r.index, r.failure) for r in results if not r.success]


@pytest.mark.slow  # two whole region searches (about 20 and 35 s)
@pytest.mark.parametrize("widened", ["deeper saturation", "wider box"])
def test_the_region_lmi_certifies_less_when_the_saturation_or_the_box_is_widened(section, widened):
    """The whole region search (LMI and cutting planes, then its numpy check) run again with the tilt limit
    lowered to 10 deg (every start saturates three times deeper) or the mass range widened to 0.5-2: it cannot
    certify the stated region there (a smaller Lur'e reach, or no Lur'e region at all).

    With the saturation alone changed the answer is known beforehand: ``x⁺ = A x + B sat_L(K x)`` is homogeneous
    in ``(x, L)`` and ``L = g_z tan(tilt)``, so the whole search (its coordinates scale with ``L``) is the same
    problem, and the reach scales by ``tan(10°) / tan(30°)`` (0.31).  The wider box has no such law: its reach
    must only fall short of the stated one."""
    stated = section["region_of_attraction"]["max_displacement_m"]
    tilt, box = (10.0, BOX) if widened == "deeper saturation" else (TILT, RC.ParameterBox(
        mass_factor=(0.5, 2.0), inertia_factor=BOX.inertia_factor, attitude_gain_factor=BOX.attitude_gain_factor,
        tau_motor_factor=BOX.tau_motor_factor))
    wide = RC.cascade_section(V, GAINS, INNER, tilt_limit_deg=tilt, rate_hz=RATE, box=box, grid_points_per_axis=2)
    reach = wide["region_of_attraction"]["max_displacement_m"]
    assert section["region_of_attraction"]["method"] == "lure"
    assert reach < stated, (wide["region_of_attraction"]["method"], reach, stated)
    if widened == "deeper saturation":
        scale = math.tan(math.radians(tilt)) / math.tan(math.radians(TILT))
        assert wide["region_of_attraction"]["method"] == "lure"
        assert reach == pytest.approx(scale * stated, rel=1e-3), (reach, scale * stated)


def test_a_cut_spreads_over_every_failing_spot_and_keeps_the_worst():
    """The cutting plane's choice (``roa_lmi._spread_worst``) against a hand-made failing set: a dense cluster of
    bad points around one corner and three mild ones far apart.  The worst-first choice of four would take the
    cluster alone; the spread choice takes the worst point and then one from each distant spot."""
    from nniquad.analysis.cascade.region_lmi import _spread_worst

    rng = np.random.default_rng(7)
    cluster = np.array([1.0, 1.0, 1.0]) + 0.01 * rng.standard_normal((10, 3))
    far = np.array([[-1.0, -1.0, -1.0], [1.0, -1.0, 0.0], [-1.0, 1.0, 0.5]])
    theta = np.vstack([cluster, far])
    margin = np.concatenate([-1.0 - rng.random(10), [-0.1, -0.2, -0.3]])  # the cluster is the worst
    picked = _spread_worst(theta, margin, 4)
    assert picked[0] == int(np.argmin(margin))  # the worst point first
    assert sorted(int(i) for i in picked[1:]) == [10, 11, 12]  # then one point of each other spot
    # fewer failing points than the cut: all of them, worst first
    assert list(_spread_worst(theta[10:], margin[10:], 4)) == [2, 1, 0]
    # a cut of one is the worst point alone
    assert list(_spread_worst(theta, margin, 1)) == [int(np.argmin(margin))]


def test_corner_points_by_hand():
    """The corners of a 3 x 3 grid in two coordinates are its four points with both coordinates at ±1; with no
    coordinate every point is one."""
    from nniquad.analysis.cascade.region_lmi import corner_points

    theta = np.array(list(itertools.product((-1.0, 0.0, 1.0), (-0.5, 0.0, 0.5))))
    assert list(corner_points(theta)) == [0, 2, 6, 8]
    assert list(corner_points(np.zeros((3, 0)))) == [0, 1, 2]


def test_a_level_refused_at_a_corner_is_infeasible_on_the_whole_box(section):
    """The region search skips a level that one corner of the box alone cannot support (``_refused_at_a_corner``).
    That is sound only if such a level is infeasible for the LMI at every point: here, at four times the stated
    level, the screen refuses (in milliseconds), and the LMI posed with ``P, Ĝ, μ`` quadratic in θ at all 81 LMI
    points is infeasible, solved independently of the screen (seconds: what the screen saves).  At the stated level
    (which the search solved) the screen passes."""
    from nniquad.analysis.cascade import region_lmi as RL
    from nniquad.config import CASCADE_LURE_MARGIN as eta

    dims, region = _dims(section), _region(section)
    fam = RF.sampled_family(V, GAINS, INNER, grid_subset(BOX, dims["x"], RC.LMI_POINTS_PER_AXIS), tilt_limit_deg=TILT,
                            rate_hz=RATE)
    d = RL.axis_data(fam, BOX, "x", dims["x"], tuple(sorted(set(dims["x"]) & set(dims["y"]))))
    centre = int(np.argmin(np.sum(d.theta ** 2, axis=1)))
    D_all = [{"x": D} for D in RL.coordinate_choices(d.A[centre], np.eye(d.A.shape[-1]), d.k_pos, float(d.L[centre]))]
    corners = RL.corner_points(d.theta)
    assert len(d.theta) == 81 and len(corners) == 16

    def screen(level):
        return RL._refused_at_a_corner({"x": d}, ("x",), D_all, level, 0.1, region.rho, d.k_pos, eta)

    assert not screen(region.level)
    assert screen(4.0 * region.level)
    status, sol = RL.solve_lure({"x": d}, D_all[0], 4.0 * region.level, 0.1, region.rho, d.k_pos, eta)
    assert sol is None and "Infeasible" in status, status
