"""The robust sampled cascade certificate (nniquad.analysis.cascade.box_certificate), each against something independent."""

from __future__ import annotations

import copy
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from nniquad.analysis.cascade import box_certificate as RC
from nniquad.analysis.cascade import family as RF, lyapunov as RL, section as RS
from nniquad.analysis.linearised_cascade import linearise_cascade
from nniquad.analysis.sampled import contraction, sampled_cascade, sampled_loop_from_blocks
from nniquad.laws.nni import Gains
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CascadeError, SolverError
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.scenarios.draws import DEFAULT_RANGES

# the cheaper test design of tests/test_certificate.py
GAINS = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56, attitude_zeta=1.132, attitude_accel_limit_rad_s2=31.14)
TILT = 30.0
RATE = 100.0
#: A box small enough for this design (its attitude loop tolerates a motor 1.1 times slower only: Routh
#: ω_a τ_m < 2 ζ_a) and for fast tests: a tenth of the Monte Carlo box in log space.
BOX = RC.ParameterBox.monte_carlo_default().scaled(0.1)


def _ok(results):
    return all(ok for _, ok, _ in results)


@pytest.fixture(scope="module")
def section(shared_json):
    # what a certificate file holds (JSON), built once per session
    return shared_json("robust-cascade-section", lambda: RC.cascade_section(
        V, GAINS, INNER, tilt_limit_deg=TILT, rate_hz=RATE, box=BOX, grid_points_per_axis=2))


@pytest.fixture(scope="module")
def checked(section):
    return RC.check_cascade_section(section, V, GAINS, INNER, tilt_limit_deg=TILT)


# ----------------------------------------------------------------------------- the box


def test_box_json_scaling_and_validation():
    mc = RC.ParameterBox.monte_carlo_default()
    assert mc.mass_factor == DEFAULT_RANGES.mass_factor and mc.tau_motor_factor == DEFAULT_RANGES.tau_motor_factor
    assert mc.inertia_factor == DEFAULT_RANGES.inertia_factor
    assert mc.attitude_gain_factor == DEFAULT_RANGES.attitude_gain_factor
    assert RC.ParameterBox.from_json(json.loads(json.dumps(mc.to_json()))) == mc
    assert set(mc.to_json()) == set(RC.BOX_KEYS)
    # log-space scaling: s = 2 squares the factors, s = 0 is the nominal point
    assert mc.scaled(2.0).tau_motor_factor == pytest.approx((0.25, 4.0))
    assert mc.scaled(0.0).vertices().tolist() == [[1.0] * 6]
    assert mc.contains(BOX) and not BOX.contains(mc)
    assert mc.vertices().shape == (64, 6)  # Jx, Jy, Jz independently
    for bad in ({"mass_factor": [0.8, 1.2]}, {**mc.to_json(), "extra": [1, 1]},
                {**mc.to_json(), "mass_factor": [1.2, 0.8]}, {**mc.to_json(), "mass_factor": [0.0, 1.0]},
                {**mc.to_json(), "mass_factor": "wide"}):
        with pytest.raises(CascadeError):
            RC.ParameterBox.from_json(bad)


def test_certify_refuses_a_grid_size_outside_the_one_rule_verify_applies():
    """certify (cascade_section) and verify share one grid-size rule; certify refuses before any solve."""
    from nniquad.config import CASCADE_GRID_MAX_POINTS_PER_AXIS

    for bad in (1, CASCADE_GRID_MAX_POINTS_PER_AXIS + 1, True, 3.0):
        with pytest.raises(CascadeError, match=rf"^grid.points_per_axis must be an integer from 2 to "
                                               rf"{CASCADE_GRID_MAX_POINTS_PER_AXIS}, got {bad!r}$"):
            RC.cascade_section(V, GAINS, INNER, tilt_limit_deg=TILT, rate_hz=RATE, box=BOX, grid_points_per_axis=bad)
    assert RC.checked_grid_size(2) == 2 and RC.checked_grid_size(CASCADE_GRID_MAX_POINTS_PER_AXIS) == CASCADE_GRID_MAX_POINTS_PER_AXIS


def test_an_invalid_grid_size_is_refused_even_after_a_valid_one_was_computed(monkeypatch):
    """cascade_section keeps the sections it computed; a grid size of 3.0 or True must still be refused after a
    section with 3 (or 1) per axis is in that store (``int(3.0) == 3`` found it, before the size was checked first:
    the suite failed only when the tamper loop's grid-3 build ran earlier on the same worker).  The builder is
    replaced by a stub, so nothing is solved."""
    import nniquad.analysis.cascade.section as S

    monkeypatch.setattr(S, "_SECTIONS", {})
    monkeypatch.setattr(S, "_cascade_section", lambda *a, **k: {"stub": k["grid_points_per_axis"]})
    assert RC.cascade_section(V, GAINS, INNER, tilt_limit_deg=TILT, rate_hz=RATE, box=BOX,
                              grid_points_per_axis=3) == {"stub": 3}
    for bad in (3.0, True):
        with pytest.raises(CascadeError, match=rf"got {bad!r}$"):
            RC.cascade_section(V, GAINS, INNER, tilt_limit_deg=TILT, rate_hz=RATE, box=BOX, grid_points_per_axis=bad)


# ----------------------------------------------------------------------------- the family vs a direct rebuild


def test_family_matches_linearise_cascade_per_point():
    """Points with the true mass and inertia nominal: exactly what linearise_cascade + sampled_cascade build."""
    pts = np.array([[1, 1, 1, 1, 0.8, 0.6], [1, 1, 1, 1, 1.25, 1.7], [1, 1, 1, 1, 1.0, 1.0]], float)
    fam = RC.sampled_family(V, GAINS, INNER, pts, tilt_limit_deg=TILT, rate_hz=RATE)
    for i, p in enumerate(pts):
        cas = linearise_cascade(V, GAINS, replace(INNER, attitude_gain_scale=p[4]), tilt_limit_deg=TILT,
                                tau_motor_s=V.tau_motor * p[5])
        sl = sampled_cascade(cas, RATE)
        assert sl.state_names == fam.state_names
        assert np.max(np.abs(fam.A_d[i] - sl.A_d)) <= 1e-12 * max(1.0, np.max(np.abs(sl.A_d)))


def _fd_plant(p_vec, x_eq, names):
    """Central finite differences of the simulator's right-hand side (independent of CasADi's AD)."""
    from nniquad.sim import EXO_FIELDS, rhs_function

    f = rhs_function("full")
    e = np.zeros(len(EXO_FIELDS))
    n = len(names)
    J = np.zeros((n, n))
    for j in range(n):
        h = 1e-6 * max(1.0, abs(x_eq[j]))
        d = np.zeros(n)
        d[j] = h
        J[:, j] = (np.asarray(f(x_eq + d, e, p_vec)).ravel() - np.asarray(f(x_eq - d, e, p_vec)).ravel()) / (2 * h)
    return J


def test_family_with_mass_and_inertia_vs_finite_differences():
    """A perturbed true mass and inertia: the equilibrium by a root solve and the Jacobian by finite differences."""
    from scipy.optimize import root

    from nniquad.analysis.linearised_cascade import hover_params
    from nniquad.sim import EXO_FIELDS, STATE_NAMES, initial_state, rhs_function

    pt = np.array([1.15, 0.85, 1.1, 0.9, 1.2, 1.4])
    fam = RC.sampled_family(V, GAINS, INNER, pt[None], tilt_limit_deg=TILT, rate_hz=RATE)
    base = hover_params(V, GAINS, INNER, TILT, None).with_(run={"sample_hold": 1.0})
    p = base.with_(plant={"m": V.m * pt[0], "Jx": V.Jx * pt[1], "Jy": V.Jy * pt[2], "Jz": V.Jz * pt[3],
                          "tau_motor": V.tau_motor * pt[5]},
                   inner={"attitude_gain_scale": pt[4]})
    names = STATE_NAMES["full"]
    f = rhs_function("full")
    e = np.zeros(len(EXO_FIELDS))
    x0 = initial_state("full", p, (0.0, 0.0))
    free = [names.index(n) for n in ("z_int", "w1", "w2", "w3", "w4")]

    def resid(u):
        x = x0.copy()
        x[free] = u
        return np.asarray(f(x, e, p.vector())).ravel()[[names.index(n) for n in ("z_dot", "w1", "w2", "w3", "w4")]]

    sol = root(resid, x0[free], tol=1e-14)
    x_eq = x0.copy()
    x_eq[free] = sol.x
    assert np.max(np.abs(np.asarray(f(x_eq, e, p.vector())).ravel())) < 1e-8
    J = _fd_plant(p.vector(), x_eq, names)
    # rebuild the sampled loop from the finite-difference blocks with the existing (independent) ZOH code
    plant = fam.state_names[:-2]
    ip = [names.index(n) for n in plant]
    ik, ih = [names.index(n) for n in ("zc_x", "zc_y")], [names.index(n) for n in ("held_x", "held_y")]
    A_p = J[np.ix_(ip, ip)]
    B_p = J[np.ix_(ip, ik + ih)] @ np.linalg.pinv(np.hstack([fam.C_k, fam.D_k]))
    sl = sampled_loop_from_blocks(A_p, B_p, fam.C_p, fam.A_k, fam.B_k, fam.C_k, fam.D_k, fam.state_names, RATE)
    scale = np.max(np.abs(sl.A_d))
    assert np.max(np.abs(fam.A_d[0] - sl.A_d)) <= 1e-5 * scale
    assert np.max(np.abs(fam.A_p[0] - A_p)) <= 1e-5 * np.max(np.abs(A_p))


def test_dropped_couplings_vanish():
    """After the fixed rotor-mode transform, the x, y, altitude and yaw blocks do not feed each other."""
    fam = RC.sampled_family(V, GAINS, INNER, BOX.vertices(), tilt_limit_deg=TILT, rate_hz=RATE)
    assert RC.coupling(fam) < RC.COUPLING_TOL
    # and the coupling measure sees a coupling when there is one: mix a state of y into x
    bad = RF.take_points(fam, np.arange(len(fam)))
    Tm, names = RC.mode_transform(fam.state_names, fam.frame)
    A = bad.A_d.copy()
    A[:, fam.state_names.index("x"), fam.state_names.index("phi")] += 1e-3
    assert RC.coupling(replace(bad, A_d=A)) > 1e-6


# ----------------------------------------------------------------------------- certificate and check


def test_section_keys_and_check_passes(section, checked):
    for key in ("rate_hz", "controller", "attitude_loop", "model", "box", "monte_carlo_default_box",
                "covers_monte_carlo_default", "lyapunov", "grid", "region_of_attraction", "margins", "matrices",
                "decay_rate_1_s"):
        assert key in section
    assert section["controller"] == "discrete" and section["attitude_loop"] == "continuous"
    assert section["box"] == BOX.to_json() and section["covers_monte_carlo_default"] is False
    g = section["grid"]
    assert g["size"] == 64 and g["ok"] and 0 < g["worst_margin"] == pytest.approx(1 - g["worst_rho"])
    assert section["region_of_attraction"]["max_displacement_m"] > 0
    assert _ok(checked), [r for r in checked if not r[1]]


def test_grid_numbers_vs_direct_rebuild(section):
    """The stored P's contraction at points rebuilt independently with linearise_cascade + sampled_cascade."""
    lo, hi = BOX.bounds()
    pts = np.array([[1, 1, 1, 1, lo[4], hi[5]], [1, 1, 1, 1, hi[4], lo[5]], [1, 1, 1, 1, 1, 1]], float)
    dims = {n: tuple(RC.POINT_NAMES.index(d) for d in section["lyapunov"]["subsystems"][n]["dims"])
            for n in RC.SUBSYSTEMS}
    lyap = {n: RC.RobustLyapunov(P=np.asarray(section["lyapunov"]["subsystems"][n]["P"]), rho=0, rho_vertices=None,
                                 spectral_radius=0, T=0.01, decay_rate_1_s=0, min_eig_P=0, status="", ok=True)
            for n in RC.SUBSYSTEMS}
    fam = RC.sampled_family(V, GAINS, INNER, pts, tilt_limit_deg=TILT, rate_hz=RATE)
    P = RL.assemble_P(lyap, dims, BOX, pts, fam.state_names, fam.frame)
    ours = RC.contraction_batch(fam.A_d, P)
    for i, p in enumerate(pts):
        cas = linearise_cascade(V, GAINS, replace(INNER, attitude_gain_scale=p[4]), tilt_limit_deg=TILT,
                                tau_motor_s=V.tau_motor * p[5])
        A_d = sampled_cascade(cas, RATE).A_d
        assert contraction(A_d, P[i]) == pytest.approx(ours[i], rel=1e-9)
        assert ours[i] < 1.0  # these points are inside the box, off its grid: contraction is seen, not certified
        assert max(abs(np.linalg.eigvals(A_d))) < 1.0


def _failed(sec):
    return [name for name, ok, _ in RC.check_cascade_section(sec, V, GAINS, INNER, tilt_limit_deg=TILT) if not ok]


@pytest.mark.parametrize("path, factor", [
    (("grid", "worst_rho"), 1 + 1e-6), (("grid", "worst_margin"), 1.01), (("decay_rate_1_s",), 1.001),
    (("region_of_attraction", "max_displacement_m"), 1.001), (("region_of_attraction", "u0_m_s2"), 1.001),
    (("lyapunov", "rho"), 0.999), (("margins", "worst", "horizontal", "pm_deg"), 1.001),
    (("lyapunov", "subsystems", "x", "spectral_radius"), 1 + 1e-6),
])
def test_tampered_number_fails(section, path, factor):
    sec = copy.deepcopy(section)
    d = sec
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = float(d[path[-1]]) * factor
    assert _failed(sec)


def test_tampered_matrix_and_perturbed_P_fail(section):
    sec = copy.deepcopy(section)
    sec["matrices"]["A_d"][0][1] *= 1 + 1e-6
    assert "nominal matrices rebuilt" in _failed(sec)
    sec = copy.deepcopy(section)
    P = np.asarray(sec["lyapunov"]["subsystems"]["x"]["P"])
    rng = np.random.default_rng(0)
    E = rng.normal(size=P.shape[1:])
    P[0] += 1e-2 * np.max(np.abs(P[0])) * (E + E.T)
    sec["lyapunov"]["subsystems"]["x"]["P"] = P.tolist()
    assert "Lyapunov LMI [x]" in _failed(sec)


def test_fail_fast_rows_are_the_full_rows_up_to_the_first_failure(section, checked):
    """``fail_fast`` changes when the re-check stops, never a row: on the true section every row runs (the same
    rows), and on an edited one the rows are the full run's, cut after its first failure."""
    assert RC.check_cascade_section(section, V, GAINS, INNER, tilt_limit_deg=TILT, fail_fast=True) == checked
    for edit in (lambda s: s["lyapunov"]["subsystems"]["x"].update(rho=s["lyapunov"]["subsystems"]["x"]["rho"] * 0.999),
                 lambda s: s["grid"].update(worst_rho=s["grid"]["worst_rho"] * (1 + 1e-6)),
                 lambda s: s["margins"]["worst"]["horizontal"].update(pm_deg=s["margins"]["worst"]["horizontal"]["pm_deg"] + 1)):
        sec = copy.deepcopy(section)
        edit(sec)
        full = RC.check_cascade_section(sec, V, GAINS, INNER, tilt_limit_deg=TILT)
        fast = RC.check_cascade_section(sec, V, GAINS, INNER, tilt_limit_deg=TILT, fail_fast=True)
        first = next(i for i, (_, ok, _) in enumerate(full) if not ok)
        assert fast == full[:first + 1] and not fast[-1][1]


@pytest.mark.parametrize("scale", [0.13, 1.0])
def test_box_wider_than_certified_fails(section, scale):
    """A wider box (still stable at 0.13, unstable at the Monte Carlo box) is not certified by the stored P."""
    sec = copy.deepcopy(section)
    wide = RC.ParameterBox.monte_carlo_default().scaled(scale)
    sec["box"] = wide.to_json()
    sec["covers_monte_carlo_default"] = wide.contains(RC.ParameterBox.monte_carlo_default())
    failed = _failed(sec)
    assert any(name.startswith("Lyapunov LMI") for name in failed), failed


# ----------------------------------------------------------------------------- the reach, by simulation


def test_reach_converges_in_the_saturated_discrete_loop(section):
    """Start at the certified reach (several directions, at the vertices): the linear loop with the norm limit converges."""
    reach = section["region_of_attraction"]["max_displacement_m"]
    L = section["region_of_attraction"]["u0_m_s2"]
    fam = RC.sampled_family(V, GAINS, INNER, BOX.vertices(), tilt_limit_deg=TILT, rate_hz=RATE)
    ix, iy = fam.state_names.index("x"), fam.state_names.index("y")
    n_steps = 1500  # 15 s; the slowest mode decays at about 1 1/s
    for ang in (0.0, 0.7, 2.0, 4.0):
        X = np.zeros((len(fam), fam.A_d.shape[1]))
        X[:, ix], X[:, iy] = reach * math.cos(ang), reach * math.sin(ang)
        for _ in range(n_steps):
            a = X @ fam.K.T
            nrm = np.linalg.norm(a, axis=1, keepdims=True)
            a = a * np.minimum(1.0, L / np.maximum(nrm, 1e-300))
            X = np.einsum("nij,nj->ni", fam.A0, X) + np.einsum("nij,nj->ni", fam.B, a)
        assert np.max(np.hypot(X[:, ix], X[:, iy])) < 1e-4 * reach
    # far outside the linear zone the same loop also saturates (the reach is not vacuous)
    assert np.max(np.abs(fam.K[0, ix])) * reach <= L * (1 + 1e-9) or reach > 0


def test_reach_nonlinear_spot_check(section):
    """The nonlinear full simulator (nominal vehicle; its sampled measurement feeds the continuous controller) from
    the certified reach converges: a spot check of the linearisation, not part of the certificate."""
    from nniquad.sim import SimOptions, simulate

    reach = section["region_of_attraction"]["max_displacement_m"]
    opts = SimOptions(model="full", motor_lag=True, sample_hold=True, inner=INNER, tilt_limit_deg=TILT,
                      horizon_s=12.0, xi0=(reach * 0.6, -reach * 0.8))
    xy = simulate(V, GAINS, opts)[0].xy
    assert np.all(np.isfinite(xy)) and float(np.hypot(*xy[-1])) < 0.05 * reach


def _fake_search(monkeypatch, edge: float):
    """Replace the certification inside :func:`RS.widest_box` by 'the scale certifies iff s <= edge' (the box's
    upper mass factor is 1.2**s, so s is read back from the box): the search logic is then checked by hand."""
    hi = RC.ParameterBox.monte_carlo_default().mass_factor[1]

    def fake_certify(vehicle, gains, inner, box, **kwargs):
        s = math.log(box.mass_factor[1]) / math.log(hi)
        if s > edge * (1 + 1e-12):
            raise SolverError(f"fake: scale {s:g} fails")
        return ("parts at", s)

    monkeypatch.setattr(RS, "_certify_box", fake_certify)
    monkeypatch.setattr(RS, "relevant_coordinates", lambda *a, **k: {"x": (0,)})


def test_box_search_halves_to_the_first_certified_scale(monkeypatch):
    _fake_search(monkeypatch, edge=0.3)
    mc = RC.ParameterBox.monte_carlo_default()
    res = RC.widest_box(V, GAINS, INNER, mc, tilt_limit_deg=TILT, rate_hz=RATE)
    assert res.scale == 0.25 and res.first_failed_scale == 0.5
    assert res.steps == ((1.0, False), (0.5, False), (0.25, True))
    assert res.parts == ("parts at", pytest.approx(0.25)) and res.dims == {"x": (0,)}


def test_widest_search_bisects_between_the_halving_steps(monkeypatch):
    _fake_search(monkeypatch, edge=0.3)
    mc = RC.ParameterBox.monte_carlo_default()
    res = RC.widest_box(V, GAINS, INNER, mc, tilt_limit_deg=TILT, rate_hz=RATE, widest=True, steps=3)
    # 0.25 certified, 0.5 failed; midpoints 0.375 (fails), 0.3125 (fails), 0.28125 (certifies)
    assert res.scale == 0.28125 and res.first_failed_scale == 0.3125 and len(res.steps) == 6
    _fake_search(monkeypatch, edge=5.0)
    res = RC.widest_box(V, GAINS, INNER, mc, tilt_limit_deg=TILT, rate_hz=RATE, widest=True, s_max=2.0)
    assert res.scale == 2.0 and res.first_failed_scale == math.inf and res.steps == ((1.0, True), (2.0, True))


def test_box_search_refuses_below_its_smallest_scale(monkeypatch):
    _fake_search(monkeypatch, edge=0.01)
    with pytest.raises(SolverError, match="scaled by 0.03"):
        RC.widest_box(V, GAINS, INNER, RC.ParameterBox.monte_carlo_default(), tilt_limit_deg=TILT, rate_hz=RATE,
                      s_min=0.03)


def test_reach_lyapunov_gives_the_closed_form_reach_of_a_scalar_loop():
    """x⁺ = a x with a = K x limited to |a| <= L: the widest invariant interval inside |K x| <= L is |x| <= L/|K|,
    i.e. P = K²/L², whatever the decay asked for above |a| (and none below it)."""
    a, k, lim = np.array([0.5, 0.6]), 2.0, 3.0
    A_v = a.reshape(2, 1, 1)
    theta = np.array([[-1.0], [1.0]])
    got = RC.reach_lyapunov(A_v, 0.01, np.array([[k]]), lim, 0.7, theta=theta)
    P = RL.affine_in(got.P, theta)
    assert P[:, 0, 0] == pytest.approx([k * k / lim ** 2] * 2, rel=1e-5)
    assert got.rho == pytest.approx(0.6, rel=1e-9) and got.ok  # the numpy contraction, not the 0.7 asked for
    assert RC.reach_lyapunov(A_v, 0.01, np.array([[k]]), lim, 0.55, theta=theta) is None  # 0.6 > 0.55: infeasible


def test_mirrored_y_block_is_found_and_rechecked_on_its_own_loops():
    rng = np.random.default_rng(3)
    A_x = 0.3 * rng.normal(size=(5, 4, 4)) / 2
    K_x = rng.normal(size=(1, 4))
    th = rng.uniform(-1, 1, size=(5, 2))
    d = np.array([1.0, -1.0, -1.0, 1.0])
    A_y, K_y = d[:, None] * A_x * d[None, :], K_x * d
    assert np.array_equal(RL.mirror_blocks((A_x, K_x, th), (A_y, K_y, th)), d)
    assert RL.mirror_blocks((A_x, K_x, th), (A_y + 1e-3, K_y, th)) is None  # not a mirror image
    assert RL.mirror_blocks((A_x, K_x, th), (A_y, K_y, th + 0.1)) is None   # other points
    P = np.stack([np.eye(4) * 2.0, 0.1 * np.eye(4), np.zeros((4, 4))])
    lx = RC.RobustLyapunov(P=P, rho=0.0, rho_vertices=np.array([]), spectral_radius=0.0, T=0.01, decay_rate_1_s=0.0,
                           min_eig_P=0.0, status="test", ok=True)
    ly = RL.mirrored_blocks(lx, d, A_y, th)
    assert ly.rho == pytest.approx(float(np.max(RC.contraction_batch(A_x, RL.affine_in(P, th)))), rel=1e-12)
    assert np.allclose(ly.P[0], d[:, None] * P[0] * d[None, :]) and "mirrored" in ly.status
    big = 10.0 * A_y  # a loop the mirrored P does not contract: refused
    assert float(np.max(RC.contraction_batch(big, RL.affine_in(ly.P, th)))) >= 1.0
    assert RL.mirrored_blocks(lx, d, big, th) is None


def test_spectral_norms_equal_the_largest_singular_value_and_fail_as_the_svd_does():
    """``√λ_max(MᵀM)`` against numpy's SVD on random, rank-one and scaled stacks; an infinite entry gives NaN and
    a NaN entry raises, as the SVD does (callers rely on both)."""
    from nniquad.analysis.cascade.lyapunov import spectral_norms

    rng = np.random.default_rng(7)
    stacks = [rng.standard_normal((64, n, n)) * 10.0 ** rng.uniform(-6, 6, (64, 1, 1)) for n in (1, 6, 23)]
    u = rng.standard_normal((16, 5, 1))
    stacks.append(u @ np.swapaxes(u, -1, -2))  # rank one: the norm is |u|²
    for M in stacks:
        svd = np.linalg.norm(M, 2, axis=(-2, -1))
        assert np.allclose(spectral_norms(M), svd, rtol=1e-13, atol=0.0)
    assert np.allclose(spectral_norms(stacks[-1]), np.sum(u[..., 0] ** 2, axis=-1), rtol=1e-13)
    M = rng.standard_normal((3, 4, 4))
    M[1, 2, 0] = np.inf
    got = spectral_norms(M)
    assert np.isnan(got[1]) and np.allclose(got[[0, 2]], np.linalg.norm(M[[0, 2]], 2, axis=(-2, -1)), rtol=1e-13)
    M[1, 2, 0] = np.nan
    with pytest.raises(np.linalg.LinAlgError):
        spectral_norms(M)
