"""LMIs: closed-form certificates, boundary perturbation, agreement with poles and frequency checks."""

from __future__ import annotations

import json

import numpy as np
import pytest

from nniquad.analysis import lmi
from nniquad.errors import GainError, SolverError, VehicleError
from nniquad.analysis.frequency import ni_interconnection_check
from nniquad.analysis.reduced_loop import PAPER_LOOP, ReducedLoop
from nniquad.laws.nni import Gains, PAPER_GAINS


@pytest.mark.parametrize("m, kp", [(0.5, 5.0), (1.3, 0.7), (0.2, 40.0)])
def test_plant_certificate_is_the_hand_derived_unique_matrix(m, kp):
    A, B, C, D = ReducedLoop(m, Gains(kp, 1.0, 1.0)).plant_matrices()
    r = lmi.ni_lemma_dissipation(A, B, C, D)
    assert r.feasible and r.status == "optimal"
    P = r.matrices["P"]
    # by hand: PB = A'C' forces P12 = 0, P22 = m; PA + A'P <= 0 then forces P11 = m kp (lossless)
    np.testing.assert_allclose(P, np.diag([m * kp, m]), rtol=1e-6, atol=1e-7 * m * kp)
    np.testing.assert_allclose(P @ A + A.T @ P, 0.0, atol=1e-6 * m * kp)
    y = lmi.ni_lemma_lanzon_petersen(A, B, C, D)
    assert y.feasible
    np.testing.assert_allclose(y.matrices["Y"] @ np.diag([m * kp, m]), np.eye(2), atol=1e-6)


def test_paper_lemma_is_infeasible_on_the_plant():
    A, B, C, _ = PAPER_LOOP.plant_matrices()
    r = lmi.ni_lemma_paper(A, B, C)
    assert not r.feasible and r.status == "infeasible"


@pytest.mark.parametrize("Gamma, delta", [(160.0, 0.6), (2.0, 0.5)])
def test_controller_certificates_by_hand(Gamma, delta):
    Ac, Bc, Cc, _ = ReducedLoop(0.5, Gains(5.0, Gamma, delta)).controller_matrices()
    paper = lmi.ni_lemma_paper(Ac, Bc, Cc)
    assert paper.feasible
    assert paper.matrices["P"][0, 0] == pytest.approx(1 / Gamma, rel=1e-7)
    # with P = 1/Gamma, dV/dt - ydot u has the matrix [[-d, (1+Gd)/2], [., -G]] (times 2):
    # det = -(1 - Gamma delta)^2 / 4 -> positive eigenvalue unless Gamma delta = 1
    if abs(Gamma * delta - 1) > 1e-3:
        assert paper.residuals["ni_dissipation_max_eig"] > 1e-6
    else:
        assert paper.residuals["ni_dissipation_max_eig"] < 1e-6
    diss = lmi.ni_lemma_dissipation(Ac, Bc, Cc)
    assert diss.feasible and diss.matrices["P"][0, 0] == pytest.approx(delta, rel=1e-4)  # unique P = delta
    sni = lmi.sni_lemma(Ac, Bc, Cc)
    assert sni.feasible
    assert sni.matrices["Y"][0, 0] == pytest.approx(1 / delta, rel=1e-7)
    assert sni.margin == pytest.approx(2 * Gamma, rel=1e-6)  # AY + YA' = -2 Gamma delta / delta
    assert not lmi.ni_dissipation_strict(Ac, Bc, Cc).feasible


def test_gamma_delta_one_makes_paper_storage_ni():
    Ac, Bc, Cc, _ = ReducedLoop(0.5, Gains(5.0, 2.0, 0.5)).controller_matrices()
    assert lmi.ni_lemma_paper(Ac, Bc, Cc).residuals["ni_dissipation_max_eig"] < 1e-6


def test_plant_is_not_sni():
    A, B, C, D = PAPER_LOOP.plant_matrices()
    r = lmi.sni_lemma(A, B, C, D)
    assert not r.feasible and r.status == "infeasible"


def test_closed_loop_decay_matches_pole_bound():
    r = lmi.closed_loop_decay(ReducedLoop(0.5, PAPER_GAINS))
    assert r.feasible
    sup = r.values["decay_rate_poles"]
    A = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).closed_loop_A_axis()
    assert sup == pytest.approx(-2 * np.max(np.linalg.eigvals(A).real), rel=1e-12)
    assert (1 - 3e-3) * sup <= r.margin <= sup * (1 + 1e-6)
    P = r.matrices["P"]
    assert np.linalg.eigvalsh(P)[0] > 0
    assert np.linalg.eigvalsh(A.T @ P + P @ A + r.margin * P)[-1] <= 1e-6 * np.linalg.norm(P, 2) * np.linalg.norm(A, 2)


@pytest.mark.parametrize("eps, expected", [(1e-3, True), (-1e-3, False)])
def test_closed_loop_lmi_at_stability_boundary(eps, expected):
    m, kp = 0.5, 5.0
    r = lmi.closed_loop_decay(ReducedLoop(m, Gains(kp=kp, Gamma=160.0, delta=(1 + eps) / (m * kp))))
    assert r.feasible is expected
    if not expected:
        assert r.status == "infeasible"


def test_random_gains_lmi_agrees_with_poles_and_frequency_check():
    rng = np.random.default_rng(20240611)
    seen = {True: 0, False: 0}
    while sum(seen.values()) < 10:
        m, kp, G, d = np.exp(rng.uniform(np.log([0.2, 1.0, 2.0, 0.1]), np.log([2.0, 30.0, 300.0, 3.0])))
        if abs(m * kp * d - 1) < 0.05:
            continue
        loop = ReducedLoop(m, Gains(kp=kp, Gamma=G, delta=d))
        poles_ok = bool(np.max(np.linalg.eigvals(loop.closed_loop_A_axis()).real) < 0)
        freq = ni_interconnection_check(loop.plant_ss(), loop.controller_ss())
        r = lmi.closed_loop_decay(loop, rtol=1e-2)
        assert r.feasible == poles_ok == freq.predicted_stable == freq.poles_stable == loop.stable
        seen[poles_ok] += 1
    assert seen[True] and seen[False]


def test_robust_mass_common_p_fails_but_mass_dependent_p_certifies():
    lo, hi = 0.4, 0.6
    common = lmi.robust_mass_decay(PAPER_LOOP, lo, hi)
    assert not common.feasible  # the slow pair's frequency moves with m: no common quadratic P
    pdlf = lmi.robust_mass_decay(PAPER_LOOP, lo, hi, parameter_dependent=True)
    assert pdlf.feasible
    assert 0 < pdlf.margin <= pdlf.values["decay_rate_poles_pointwise_min"] * (1 + 1e-6)
    assert lmi.robust_mass_decay(PAPER_LOOP, 0.499, 0.501).feasible
    # below the exact Routh bound m > 1/(kp delta) = 1/3 kg nothing can be certified
    assert pdlf.values["m_min_exact"] == pytest.approx(1 / 3)
    assert not lmi.robust_mass_decay(PAPER_LOOP, 0.3, 0.6, parameter_dependent=True).feasible
    with pytest.raises(VehicleError):  # a mass range describes the vehicle, not the gains
        lmi.robust_mass_decay(PAPER_LOOP, 0.6, 0.4)


def test_region_of_attraction_is_invariant_and_attractive_in_simulation():
    from scipy.integrate import solve_ivp

    m, kp, G, d = 0.5, 5.0, 160.0, 0.6
    u0 = lmi.axis_acceleration_limit(9.81, 30.0, "inscribed")
    assert u0 == pytest.approx(9.81 * np.tan(np.radians(30)) / np.sqrt(2))
    assert lmi.axis_acceleration_limit(9.81, 30.0) == pytest.approx(9.81 * np.tan(np.radians(30)))
    loop = ReducedLoop(m, Gains(kp, G, d))
    r = lmi.region_of_attraction(loop, u0)
    assert r.feasible and r.values["max_displacement_m"] > kp * 0 + u0 / kp  # beyond the linear (unsaturated) zone
    P = r.matrices["P"]
    x0 = np.array([r.margin, 0.0, 0.0])
    assert x0 @ P @ x0 == pytest.approx(1.0, abs=1e-5)
    A0, B, K = loop.saturation_split()

    def f(t, x):
        return A0 @ x + B[:, 0] * np.clip(K @ x, -u0, u0)[0]

    rng = np.random.default_rng(3)
    Lc = np.linalg.cholesky(P)
    starts = [x0 * (1 - 1e-6)]
    for _ in range(3):
        v = rng.normal(size=3)
        starts.append(np.linalg.solve(Lc.T, v / np.linalg.norm(v)) * (1 - 1e-6))
    for xs in starts:
        sol = solve_ivp(f, (0.0, 150.0), xs, method="LSODA", rtol=1e-8, atol=1e-10, dense_output=True)
        X = sol.sol(np.linspace(0.0, 150.0, 1501))
        V = np.einsum("it,ij,jt->t", X, P, X)
        assert V.max() <= 1.0 + 1e-6  # invariance: never leaves the ellipsoid
        assert V[-1] < 0.05  # attractivity: V decays (slowly: the dominant pair has zeta ~ 0.013)


def test_nan_data_raises_solver_error():
    A, B, C, D = PAPER_LOOP.plant_matrices()
    A = A.copy()
    A[0, 0] = np.nan
    for fn in (lmi.ni_lemma_paper, lmi.ni_lemma_dissipation, lmi.ni_lemma_lanzon_petersen, lmi.sni_lemma,
               lmi.ni_dissipation_strict):
        with pytest.raises(SolverError, match="non-finite"):
            fn(A, B, C)
    with pytest.raises(GainError):  # a NaN mass is caught earlier, by the loop itself
        lmi.closed_loop_decay(ReducedLoop(float("nan"), PAPER_GAINS))
    with pytest.raises(GainError):  # bad gains are caught earlier, by the gain set itself
        Gains(kp=5.0, Gamma=160.0, delta=float("nan"))


def test_unbounded_and_crash_become_solver_error(monkeypatch):
    import cvxpy as cp

    x = cp.Variable()
    with pytest.raises(SolverError, match="unbounded"):
        lmi.solver.solve(cp.Problem(cp.Maximize(x), [x >= 0]), "toy")
    prob = cp.Problem(cp.Minimize(x), [x >= 0])

    def boom(*a, **k):
        raise cp.error.SolverError("crashed")

    monkeypatch.setattr(prob, "solve", boom)
    with pytest.raises(SolverError, match="Clarabel failed"):
        lmi.solver.solve(prob, "toy")


def test_failed_recheck_is_not_feasible(monkeypatch):
    monkeypatch.setattr(lmi.checks, "RTOL", -1.0)  # no answer can pass a negative tolerance
    Ac, Bc, Cc, _ = PAPER_LOOP.controller_matrices()
    r = lmi.ni_lemma_paper(Ac, Bc, Cc)
    assert r.status == "optimal" and not r.feasible and "re-check failed" in r.note


def test_run_all_json():
    results = lmi.run_all(ReducedLoop(0.5, PAPER_GAINS, g=9.81))
    names = [r.name for r in results]
    assert "ni_lemma_paper[plant]" in names and "region_of_attraction[x]" in names
    data = json.loads(json.dumps([r.to_json() for r in results]))
    for entry in data:
        assert {"name", "feasible", "status", "residuals", "matrices"} <= set(entry)


def test_thrust_mass_model_by_hand_and_robust_certificate():
    m_hat, kp, G, d = 0.5, 5.0, 160.0, 0.6
    nominal = ReducedLoop(m_hat, PAPER_GAINS)
    np.testing.assert_array_equal(nominal.with_mass(m_hat, thrust_model=True).closed_loop_A_axis(),
                                  ReducedLoop(m_hat, Gains(kp, G, d)).closed_loop_A_axis())
    for m in (0.3, 0.8):
        A = nominal.with_mass(m, thrust_model=True).closed_loop_A_axis()
        hand = [1, G * d, kp * m_hat / m, G * (kp * m_hat * d - 1) / m]  # worked out by hand
        np.testing.assert_allclose(np.poly(A), hand, rtol=1e-12)
    r = lmi.robust_mass_decay(nominal, 0.3, 1.0, parameter_dependent=True, thrust_model=True)
    assert r.feasible and r.values["m_min_exact"] == 0.0  # stable for every true mass since m_hat kp d > 1
    assert 0 < r.margin <= r.values["decay_rate_poles_pointwise_min"] * (1 + 1e-9)


def test_norm_limited_region_certifies_the_2d_loop_in_simulation():
    """The single-axis LMI with the full limit certifies the 2-D loop whose command *norm* is saturated."""
    from scipy.integrate import solve_ivp

    m, kp, G, d = 0.5, 5.0, 160.0, 0.6
    u0 = lmi.axis_acceleration_limit(9.81, 30.0)
    loop = ReducedLoop(m, Gains(kp, G, d))
    r = lmi.region_of_attraction(loop, u0)
    assert r.feasible
    P2 = np.kron(np.eye(2), r.matrices["P"])  # state [x, x', zx, y, y', zy]
    A0, B, K = loop.saturation_split()

    def f(_t, x):
        a = np.array([K @ x[:3], K @ x[3:]]).ravel()
        n = np.linalg.norm(a)
        a = a if n <= u0 else a * (u0 / n)
        return np.concatenate([A0 @ x[:3] + B[:, 0] * a[0], A0 @ x[3:] + B[:, 0] * a[1]])

    rng = np.random.default_rng(11)
    L = np.linalg.cholesky(P2)
    starts = [np.array([2.0, 0, 0, -1.5, 0, 0]) * r.margin / 2.5 * (1 - 1e-6)]  # the paper's direction, on the boundary
    for _ in range(3):
        v = rng.normal(size=6)
        starts.append(np.linalg.solve(L.T, v / np.linalg.norm(v)) * (1 - 1e-6))
    for xs in starts:
        sol = solve_ivp(f, (0.0, 150.0), xs, method="LSODA", rtol=1e-8, atol=1e-10, dense_output=True)
        X = sol.sol(np.linspace(0.0, 150.0, 1501))
        V = np.einsum("it,ij,jt->t", X, P2, X)
        assert V.max() <= 1.0 + 1e-6
        assert V[-1] < 0.05
    # the start at the certified radius really drives the norm limit (not a vacuous check)
    a0 = np.array([K @ starts[0][:3], K @ starts[0][3:]]).ravel()
    assert np.linalg.norm(a0) > 2 * u0


# ------------------------------------------------------------------------------ every re-check can fail
#
# A solver's "optimal" proves nothing by itself: each LMI function must re-check the returned matrices with
# numpy.  These tests hand every function a wrong answer labelled "optimal" and demand feasible=False; an
# LMI function that skipped (part of) its re-check would report the wrong answer as certified.

def _lmi_cases():
    from nniquad.analysis.lmi import decay, ni
    from nniquad.analysis.lmi import reduced_region as roa
    A, B, C, D = PAPER_LOOP.plant_matrices()
    Ac, Bc, Cc, _ = PAPER_LOOP.controller_matrices()
    u0 = lmi.axis_acceleration_limit(PAPER_LOOP.g)
    return {
        "ni_lemma_paper[controller]": (ni, lambda: lmi.ni_lemma_paper(Ac, Bc, Cc)),
        "ni_lemma_dissipation[plant]": (ni, lambda: lmi.ni_lemma_dissipation(A, B, C, D)),
        "ni_lemma_dissipation[controller]": (ni, lambda: lmi.ni_lemma_dissipation(Ac, Bc, Cc)),
        "ni_lemma_lanzon_petersen[plant]": (ni, lambda: lmi.ni_lemma_lanzon_petersen(A, B, C, D)),
        "ni_lemma_lanzon_petersen[controller]": (ni, lambda: lmi.ni_lemma_lanzon_petersen(Ac, Bc, Cc)),
        "sni_lemma[controller]": (ni, lambda: lmi.sni_lemma(Ac, Bc, Cc)),
        "ni_dissipation_strict[controller]": (ni, lambda: lmi.ni_dissipation_strict(Ac, Bc, Cc)),
        "closed_loop_decay": (decay, lambda: lmi.closed_loop_decay(PAPER_LOOP, rtol=1e-1)),
        "robust_mass_decay[common_P]": (decay, lambda: lmi.robust_mass_decay(PAPER_LOOP, 0.499, 0.501, rtol=1e-1)),
        "robust_mass_decay[pdlf]": (decay, lambda: lmi.robust_mass_decay(PAPER_LOOP, 0.45, 0.55, rtol=1e-1,
                                                                         parameter_dependent=True)),
        "robust_mass_decay[pdlf,thrust_model]": (decay, lambda: lmi.robust_mass_decay(
            PAPER_LOOP, 0.4, 0.6, rtol=1e-1, parameter_dependent=True, thrust_model=True)),
        "region_of_attraction": (roa, lambda: lmi.region_of_attraction(PAPER_LOOP, u0)),
    }


def _lying_solver(corrupt):
    """A ``solve`` that solves for real, then replaces the answer by ``corrupt(value)`` and says 'optimal'."""
    import cvxpy as cp

    def solve(problem, name):
        lmi.solver.solve(problem, name)
        for v in problem.variables():
            value = -np.ones(v.shape) if v.value is None else np.asarray(v.value, dtype=float)
            v.value = corrupt(value)
        return cp.OPTIMAL

    return solve


def _negate(value):
    return -value


def _congruence(value):
    """``D V D`` with ``D = diag(2, 3, ...)``: keeps a positive definite matrix positive definite, breaks the rest."""
    if value.ndim == 2 and value.shape[0] == value.shape[1]:
        d = np.diag(np.arange(2.0, value.shape[0] + 2.0))
        return d @ value @ d
    return 4.0 * value


@pytest.mark.parametrize("case", list(_lmi_cases()))
def test_every_lmi_rejects_a_negated_answer(monkeypatch, case):
    module, run = _lmi_cases()[case]
    if case != "ni_dissipation_strict[controller]":  # strict dissipation is infeasible for any P (see its docstring)
        assert run().feasible, "the honest answer must certify, or the test below proves nothing"
    monkeypatch.setattr(module, "solve", _lying_solver(_negate))
    r = run()
    assert r.status == "optimal" and not r.feasible


@pytest.mark.parametrize("case", ["ni_lemma_paper[controller]", "ni_lemma_dissipation[plant]",
                                  "ni_lemma_dissipation[controller]", "ni_lemma_lanzon_petersen[plant]",
                                  "ni_lemma_lanzon_petersen[controller]", "sni_lemma[controller]"])
def test_ni_lemmas_reject_a_positive_but_wrong_storage(monkeypatch, case):
    """P (or Y) stays positive definite but violates the lemma's equality or dissipation: a re-check of P > 0
    alone would pass it."""
    module, run = _lmi_cases()[case]
    monkeypatch.setattr(module, "solve", _lying_solver(_congruence))
    r = run()
    M = r.matrices.get("P", r.matrices.get("Y"))
    assert np.linalg.eigvalsh(M)[0] > 0
    assert r.status == "optimal" and not r.feasible


def _identity(value):
    return np.eye(value.shape[0]) if value.ndim == 2 and value.shape[0] == value.shape[1] else value


@pytest.mark.parametrize("case", ["closed_loop_decay", "robust_mass_decay[common_P]"])
def test_decay_lmis_reject_a_positive_matrix_that_certifies_no_decay(monkeypatch, case):
    """The solver 'returns' P = I in the scaled state (P >= I holds).  In those coordinates A + A' has a zero
    2x2 block (position, velocity) coupled to the controller state, so it is indefinite: I certifies no decay.
    A re-check of P >= I without the rate the matrix really certifies would accept it."""
    module, run = _lmi_cases()[case]
    monkeypatch.setattr(module, "solve", _lying_solver(_identity))
    r = run()
    assert r.status == "optimal" and not r.feasible


# ------------------------------------------------------------------------------ scaling of the ROA LMI

def _box_edge_loop():
    """The gains the quick tuner reached at the edge of the old search box: kp = 2000, Gamma = 6152, delta on the
    sector bound (u = 0).  Unscaled and unpolished, Clarabel's 'optimal' answer failed the re-check by 3e-5."""
    from nniquad.config import GAMMA_MAX
    from nniquad.model.vehicle import PAPER_VEHICLE

    kp = 2000.0
    return ReducedLoop.from_vehicle(PAPER_VEHICLE, Gains(kp, 6152.0, 1.0 / (GAMMA_MAX * PAPER_VEHICLE.m * kp)))


def test_region_of_attraction_at_the_box_edge_is_certified_and_confirmed_independently():
    from scipy.integrate import solve_ivp

    from nniquad.analysis.lmi import checks

    loop = _box_edge_loop()
    u0 = lmi.axis_acceleration_limit(loop.g)
    A0, B, K = loop.saturation_split()
    assert np.max(np.linalg.eigvals(A0 + B @ K).real) < 0  # Hurwitz: a positive reach must exist
    r = lmi.region_of_attraction(loop, u0)
    assert r.feasible  # the solver's answer passed the numpy re-check in the original variables
    reach = r.values["max_displacement_m"]
    # positive, and beyond the linear zone u0/kp of the saturation (else the saturation would never act)
    assert reach > u0 / loop.gains.kp
    # the numpy re-check, recomputed here from the returned P, G, T alone (original variables)
    P, G, T = r.matrices["P"], r.matrices["G"], r.matrices["T"]
    assert checks.eigmin(P) > 0 and T[0, 0] > 0
    assert checks.eigmax(checks.roa_decrease_matrix(A0 + B @ K, B, P, G, T)) < 0
    assert checks.roa_inclusion_margin(K, G, np.linalg.inv(P), u0) >= 0
    assert checks.ellipsoid_level(P, [reach, 0.0, 0.0]) <= 1.0
    # and by simulation of the saturated loop from the certified start: stays in the ellipsoid and converges
    def f(_t, x):
        return A0 @ x + B[:, 0] * np.clip(K @ x, -u0, u0)[0]

    x0 = np.array([reach, 0.0, 0.0]) * (1 - 1e-6)
    assert abs(K @ x0)[0] > u0  # the start saturates the command
    sol = solve_ivp(f, (0.0, 20.0), x0, method="LSODA", rtol=1e-9, atol=1e-12, dense_output=True)
    X = sol.sol(np.linspace(0.0, 20.0, 4001))
    V = np.einsum("it,ij,jt->t", X, P, X)
    assert V.max() <= 1.0 + 1e-6 and V[-1] < 1e-3
    # the tuner's one number agrees
    assert lmi.certified_reach(loop) == pytest.approx(reach, rel=1e-9)


@pytest.mark.parametrize("scaling", ["balanced", "physical"])
def test_region_of_attraction_scaling_changes_no_answer_for_well_scaled_gains(scaling):
    """Paper gains and the committed full-model certificate's gains: the scaled problem's reach equals the
    unscaled one (the scaling is a congruence: exact up to the solver's tolerance)."""
    from nniquad.model.vehicle import PAPER_VEHICLE

    u0 = lmi.axis_acceleration_limit(PAPER_VEHICLE.g)
    for gains in (PAPER_GAINS, Gains(33.01, 88.46, 0.0757)):
        loop = ReducedLoop.from_vehicle(PAPER_VEHICLE, gains)
        plain = lmi.region_of_attraction(loop, u0, scaling="none")
        scaled = lmi.region_of_attraction(loop, u0, scaling=scaling)
        assert plain.feasible and scaled.feasible
        assert scaled.margin == pytest.approx(plain.margin, rel=1e-4)
        assert f"scaling {scaling}" in scaled.note


def test_region_of_attraction_is_certified_at_every_corner_of_the_old_search_box():
    import itertools
    import math

    from nniquad.config import GAMMA_MAX
    from nniquad.model.vehicle import PAPER_VEHICLE as V

    u0 = lmi.axis_acceleration_limit(V.g)
    for kp, u, gd in itertools.product((0.5, 2000.0), (0.0, 4.0), (0.05, 2500.0)):
        delta = math.exp(u) / (GAMMA_MAX * V.m * kp)
        r = lmi.region_of_attraction(ReducedLoop.from_vehicle(V, Gains(kp, gd / delta, delta)), u0)
        assert r.feasible and r.margin > u0 / kp, (kp, u, gd, r.note)


def test_region_of_attraction_scaling_names_are_checked():
    with pytest.raises(GainError, match="scaling"):
        lmi.region_of_attraction(PAPER_LOOP, 5.0, scaling="tilted")
    scalings = lmi.reduced_region.roa_scalings(*[np.asarray(m) for m in _split(PAPER_LOOP)], 5.0)
    assert set(scalings) == set(lmi.reduced_region.ROA_SCALINGS)
    d, omega, psi = scalings["physical"]
    kp, m = PAPER_LOOP.gains.kp, PAPER_LOOP.m
    np.testing.assert_allclose(d, 5.0 / kp * np.array([1.0, np.sqrt(kp), m * kp]))
    assert omega == pytest.approx(np.sqrt(kp)) and psi == 5.0


def _split(loop):
    A0, B, K = loop.saturation_split()
    return A0 + B @ K, B, K
