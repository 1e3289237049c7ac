"""The integral laws ``nni_i`` and ``sni2_i`` (:mod:`nniquad.laws.integral`) against hand formulas and hand loops.

Each check has an independent reference: the base law's steady offset ``F/(m̂ k_p (1 - γ))`` with ``γ`` from
the gains by hand, the transfer function ``-k_p - k_i/s + C(s)/m̂`` with ``C(s)`` written out, a discrete step
and a closed loop written here in numpy from the law's equations (not from its matrices), and the saturated
start measured with and without anti-windup.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from nniquad.certificates.certificate import read_certificate
from nniquad.control.discrete import DiscreteLaw
from nniquad.laws import integral_variant, law_named
from nniquad.laws.integral import reduced_loop_poles
from nniquad.sim import SimOptions, simulate

DATA = Path(__file__).resolve().parents[1] / "notebooks" / "data"
#: A committed design of each base law (the integral variant's seed is built from it).
DESIGNS = {"nni": DATA / "full_model_certificate.json", "sni2": DATA / "sni2_cascade_certificate.json"}
RATE_HZ = 100.0


def _design(base: str):
    """``(vehicle, base gains, integral gains seeded from them, tilt limit [deg])``."""
    cert = read_certificate(DESIGNS[base])
    law = integral_variant(cert.gains.law)
    return cert.vehicle, cert.gains, law.seed_from(cert.gains, cert.vehicle.m), cert.tilt_limit_deg


def _base_c(gains, s: complex) -> complex:
    """``C(s)`` of the base controller, written out from the law's docstring (N/m)."""
    if hasattr(gains, "Gamma"):
        return gains.Gamma / (s + gains.Gamma * gains.delta)
    return gains.k / (s * s + 2 * gains.zeta * gains.omega * s + gains.omega**2)


def _gamma(gains, m_hat: float) -> float:
    """The base law's DC loop gain ``C(0)/(m̂ k_p)`` by hand."""
    return _base_c(gains, 0.0).real / (m_hat * gains.kp)


def test_registry_variant_and_interface():
    for base in ("nni", "sni2"):
        law = integral_variant(law_named(base))
        assert law.name == f"{base}_i" and law.integral and not law_named(base).integral
        assert integral_variant(law) is law and law.law_classes == ("cascade",) and not law.ni_structure
        assert law.sim_state_names[-2:] == ("zci_x", "zci_y")
        assert law.gain_names == (*[n for n in law_named(base).gain_names if n != "kpy"], "ki")
        v, _, gi, _ = _design(base)
        assert law.static_stiffness(gi, v.m) == (math.inf, math.inf)
        assert law.wind_equilibrium(gi, v.m, (0.3, -0.2)) == (0.0, 0.0)
        q = law.encode(gi, v.m, 0.8, "cascade")
        back = law.decode(q, v.m, 0.8, "cascade")
        assert all(math.isclose(a, b, rel_tol=1e-12) for a, b in zip(back.values().values(), gi.values().values()))
        lo, hi = law.box("cascade", _Limits())
        assert len(lo) == len(hi) == len(q) == law.dims("cascade")
    with pytest.raises(ValueError, match="no integral variant"):
        integral_variant(law_named("pd_velocity"))


class _Limits:
    kp_max, pole_max, control_rate_hz, rk4_pole_max = 500.0, 300.0, 100.0, 1e4


@pytest.mark.parametrize("base", sorted(DESIGNS))
def test_transfer_function_is_minus_kp_minus_ki_over_s_plus_c_over_m(base):
    v, g, gi, _ = _design(base)
    A, B, C, D = gi.law.matrices(gi, v.m)
    for w in (0.05, 0.7, 3.0, 40.0):
        s = 1j * w
        got = (C @ np.linalg.solve(s * np.eye(A.shape[0]) - A, B) + D)[0, 0]
        want = -gi.kp - gi.ki / s + _base_c(g, s) / v.m
        assert abs(got - want) <= 1e-12 * abs(want)


@pytest.mark.parametrize("base", sorted(DESIGNS))
def test_constant_force_offset_vanishes_with_integral_action(base):
    """Under a constant force ``F`` the base law stops at ``F/(m̂ k_p (1 - γ))``, the integral law at the setpoint.

    Tolerance: the remaining transient of the integral loop decays like ``e^{-σ t}``, ``σ`` its slowest pole's
    decay rate (:func:`reduced_loop_poles`); the run lasts ``15/σ``, so the transient is ``e^{-15}`` (3e-7) of
    its start, which is of the order of the base offset (what the integrator has to remove): ``1e-4`` of that
    offset leaves a factor of about 300 for the modes' residues.
    """
    v, g, gi, _ = _design(base)
    F = 0.1 * v.m * v.g  # the 10 % of the weight
    sigma = float(np.min(np.abs(reduced_loop_poles(gi.law, gi, v.m).real)))
    horizon = 15.0 / sigma
    o = SimOptions(model="reduced", horizon_s=horizon, xi0=(0.0, 0.0), wind_N=(F, 0.0), output_dt_s=0.05)
    plain, integral = (simulate(v, gains, o)[0] for gains in (g, gi))
    offset = F / (v.m * g.kp * (1.0 - _gamma(g, v.m)))
    print(f"{base}: F = {F:.4g} N, base offset {plain.xy[-1, 0]:.6g} m (hand {offset:.6g} m), "
          f"integral {integral.xy[-1, 0]:.3g} m after {horizon:.3g} s")
    assert plain.xy[-1, 0] == pytest.approx(offset, rel=1e-6)
    assert abs(integral.xy[-1, 0]) < 1e-4 * offset and abs(integral.xy[-1, 1]) < 1e-12


def _hand_nni_i_step(gains, m_hat, T, L, zc, q, xi):
    """One discrete step of ``nni_i`` from its equations: exact ZOH of ``z' = -Γδ z + Γ ξ``, ``q`` by back-calculation."""
    a = -gains.kp * xi + zc / m_hat - gains.ki * q
    sat = a * (L / max(math.hypot(*a), L))
    e = math.exp(-gains.Gamma * gains.delta * T)
    k_s = gains.kp - 1.0 / (m_hat * gains.delta)  # the base's static stiffness: kp minus C(0)/m̂, C(0) = 1/δ
    return e * zc + (1 - e) / gains.delta * xi, q + T * (xi + (a - sat) / k_s), sat


def test_discrete_step_equals_the_hand_step_saturated_and_not():
    v, _, gi, tilt = _design("nni")
    ctrl = DiscreteLaw.from_gains(gi, v.m, v.g, RATE_HZ, tilt)
    L = v.g * math.tan(math.radians(tilt))
    zc, q = np.array([0.3, -0.1]), np.array([0.02, 0.05])
    for xi, saturated in ((np.array([2.5, -1.0]), True), (np.array([0.01, 0.02]), False)):
        z = np.array([zc[0], zc[1], q[0], q[1]])  # state-major, axis-minor: zc_x, zc_y, q_x, q_y
        z_next, a, _ = ctrl.step(z, xi)
        zc_h, q_h, a_h = _hand_nni_i_step(gi, v.m, ctrl.T, L, zc, q, xi)
        np.testing.assert_allclose(z_next, np.r_[zc_h, q_h], rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(a, a_h, rtol=1e-13)
        assert (math.hypot(*(-gi.kp * xi + zc / v.m - gi.ki * q)) > L) is saturated
        if saturated:  # the anti-windup term is there: without it q would have moved by T ξ
            assert np.all(np.abs(q_h - (q + ctrl.T * xi)) > 1e-3)


def _hand_loop(gi, m_hat, T, L, xi0, n, anti_windup=True):
    """The reduced loop ``ξ'' = a`` (``a`` held over each period: exact double-integrator update) closed by
    :func:`_hand_nni_i_step`; returns the positions and the integrator states ``(x, y, q_x, q_y)`` at the samples."""
    x, vel = np.array(xi0, float), np.zeros(2)
    zc, q, xs = np.zeros(2), np.zeros(2), []
    for _ in range(n):
        xs.append(np.r_[x, q])
        zc_n, q_n, a = _hand_nni_i_step(gi, m_hat, T, L, zc, q, x)
        if not anti_windup:
            q_n = q + T * x
        zc, q = zc_n, q_n
        x, vel = x + T * vel + 0.5 * T * T * a, vel + T * a
    return np.array(xs)


def test_simulator_discrete_update_equals_the_hand_loop_through_saturation():
    """The simulator's discrete law (reduced model, 100 Hz) from a 2.5 m start, saturated at first, against the
    hand loop: the sample update with its anti-windup term is the hand step."""
    v, _, gi, tilt = _design("nni")
    T, n = 1.0 / RATE_HZ, 300
    tr = simulate(v, gi, SimOptions(model="reduced", horizon_s=n * T, output_dt_s=T, xi0=(2.5, -1.0),
                                    controller_sampling="discrete", tilt_limit_deg=tilt))[0]
    want = _hand_loop(gi, v.m, T, v.g * math.tan(math.radians(tilt)), (2.5, -1.0), n)
    q = tr.state[:, [tr.state_names.index("zci_x"), tr.state_names.index("zci_y")]]
    assert np.max(np.abs(tr.xy[:n] - want[:, :2])) < 1e-9
    # the state recorded at t_k is the q held over the period that ends there (the advance is the next step's)
    assert np.max(np.abs(q[1:n] - want[:-1, 2:])) < 1e-9
    tilt_cmd = tr.outputs[:, tr.output_names.index("tilt_cmd")]
    assert np.max(tilt_cmd) == pytest.approx(math.radians(tilt), rel=1e-9)  # it did saturate, for a while
    assert np.count_nonzero(tilt_cmd > math.radians(tilt) * (1 - 1e-9)) > 10


@pytest.mark.parametrize("base", sorted(DESIGNS))
def test_saturated_start_converges_and_anti_windup_does_not_raise_the_overshoot(base):
    """The 2.5 m start of the discrete law on the reduced loop with and without anti-windup (the same law with
    ``W = None``): both converge, and the overshoot with anti-windup is not larger."""
    v, _, gi, tilt = _design(base)
    ctrl = DiscreteLaw.from_gains(gi, v.m, v.g, RATE_HZ, tilt)
    runs = {}
    for name, c in (("anti-windup", ctrl), ("none", dataclasses.replace(ctrl, W=None))):
        x, vel, z, xs = np.array([2.5, 0.0]), np.zeros(2), ctrl.start(np.array([2.5, 0.0])), []
        for _ in range(int(40 * RATE_HZ)):
            z, a, _ = c.step(z, x)
            x, vel = x + c.T * vel + 0.5 * c.T**2 * a, vel + c.T * a
            xs.append(x[0])
        runs[name] = np.array(xs)
    over = {k: max(0.0, -float(np.min(x))) for k, x in runs.items()}
    print(f"{base}_i ki={gi.ki:.4g}: overshoot with anti-windup {over['anti-windup']:.4f} m, "
          f"without {over['none']:.4f} m")
    assert abs(runs["anti-windup"][-1]) < 1e-4 and abs(runs["none"][-1]) < 1e-2
    assert over["anti-windup"] <= over["none"]


def test_continuous_anti_windup_equals_the_hand_ode_through_saturation():
    """The simulator's continuous law (reduced model) from a 2.5 m start against ``scipy.integrate.solve_ivp`` of
    the hand-written loop ``ξ'' = sat(a)``, ``z' = -Γδ z + Γ ξ``, ``q' = ξ + (a - sat(a))/k_s``; the tolerance is
    the RK4 step's error across the saturation's kinks (measured 1e-7 at the default step)."""
    from scipy.integrate import solve_ivp

    v, _, gi, tilt = _design("nni")
    L = v.g * math.tan(math.radians(tilt))
    k_s = gi.kp - 1.0 / (v.m * gi.delta)

    def rhs(_t, s):
        x, vel, zc, q = s[0:2], s[2:4], s[4:6], s[6:8]
        a = -gi.kp * x + zc / v.m - gi.ki * q
        sat = a * (L / max(math.hypot(*a), L))
        return np.r_[vel, sat, -gi.Gamma * gi.delta * zc + gi.Gamma * x, x + (a - sat) / k_s]

    t = np.arange(0.0, 3.0 + 1e-9, 0.05)
    ref = solve_ivp(rhs, (0.0, 3.0), np.r_[2.5, -1.0, np.zeros(6)], t_eval=t, rtol=1e-11, atol=1e-12).y
    tr = simulate(v, gi, SimOptions(model="reduced", horizon_s=3.0, output_dt_s=0.05, xi0=(2.5, -1.0),
                                    tilt_limit_deg=tilt))[0]
    q = tr.state[:, [tr.state_names.index("zci_x"), tr.state_names.index("zci_y")]]
    assert np.max(np.abs(tr.xy - ref[0:2].T)) < 1e-5 and np.max(np.abs(q - ref[6:8].T)) < 1e-5
    assert np.max(np.abs(q - ref[6:8].T)) < 1e-2 * np.max(np.abs(ref[6:8]))  # q is not ~0 (the check has teeth)


def test_two_axis_gains_have_no_integral_variant():
    from nniquad.errors import GainError
    from nniquad.laws import Gains

    law = integral_variant(law_named("nni"))
    two = Gains(kp=5.0, Gamma=160.0, delta=0.6, kpy=6.0)
    assert law.seed_from(two, 1.0) is None
    with pytest.raises(GainError, match="one kp"):
        law.with_ki(two, 0.1)
    assert law.with_ki(Gains(kp=5.0, Gamma=160.0, delta=0.6), 0.1).values() == dict(kp=5.0, Gamma=160.0, delta=0.6,
                                                                                     ki=0.1)
