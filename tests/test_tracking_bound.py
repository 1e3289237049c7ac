"""The certified tracking-error bound against closed forms and against an independent simulation.

The simulation flies references through the raw sampled-data loop: the full 19-state linearised cascade (both axes,
coupled as the Jacobians have it) with the reference's own integrators, exact ZOH over sub-steps of the period,
the law updated at the samples: nothing of the bound's error coordinates, axis split, fine grid or Taylor terms.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from nniquad.analysis.cascade.family import sampled_family
from nniquad.analysis.tracking_bound import classify_reference, tracking_bound
from nniquad.analysis.tracking_l1 import HybridLoop, peak_free, peak_gain
from nniquad.certificates.sections import certificate_gains, certificate_inner_loop, certificate_vehicle

CERT = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"

SUB = 10        # sub-steps per control period of the simulation
PERIODS = 700   # 7 s: the kernel has decayed to ~1e-3 of its peak


@pytest.fixture(scope="module")
def design():
    cert = json.loads(CERT.read_text())
    v, g, inner = certificate_vehicle(cert), certificate_gains(cert), certificate_inner_loop(cert)
    fam = sampled_family(v, g, inner, np.ones((1, 6)))
    return fam, tracking_bound(v, g, inner)


# ------------------------------------------------------------------------------------------- closed forms


def test_peak_gain_matches_the_closed_form_l1_norm_of_a_damped_oscillator():
    # y'' + 2a y' + (a² + b²) y = w: h(t) = e^{-at} sin(bt)/b, ∫|h| = coth(aπ/2b)/(a² + b²) (a jump that does nothing)
    a, b = 0.7, 3.0
    loop = HybridLoop(np.array([[-2 * a, -(a * a + b * b)], [1.0, 0.0]]), np.array([1.0, 0.0]), np.eye(2), 0.01,
                      ("y_dot", "y"))
    exact = 1.0 / math.tanh(a * math.pi / (2 * b)) / (a * a + b * b)
    got = peak_gain(loop, loop.row("y")).continuous
    assert exact <= got <= 1.01 * exact


def test_peak_free_bounds_the_dense_free_response():
    a, b = 0.4, 5.0
    A = np.array([[-2 * a, -(a * a + b * b)], [1.0, 0.0]])
    loop = HybridLoop(A, np.zeros(2), np.eye(2), 0.02, ("y_dot", "y"))
    x0 = np.array([1.0, 0.3])
    t = np.linspace(0.0, 20.0, 20001)
    dense = max(abs((sla.expm(A * s) @ x0)[1]) for s in t[::5])
    got = peak_free(loop, loop.row("y"), x0)
    assert dense <= got <= 1.01 * dense


# ------------------------------------------------------------------------------------------- the raw loop


def _raw(fam, order: int, ff: bool, drive: np.ndarray, ref0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Errors (steps+1, 2, B) and commands (periods, 2, B) of B references at once.

    ``drive`` (steps, 2, B) is the reference's top derivative held over each sub-step (its acceleration with
    ``order`` 2, its jerk with 3); ``ref0`` (2, order, B) its initial state; the vehicle starts on it, level.
    """
    n_p = fam.A_p.shape[1]
    n = n_p + 2 * order
    A, B = np.zeros((n, n)), np.zeros((n, 4))
    A[:n_p, :n_p], B[:n_p, :2] = fam.A_p[0], fam.B_p[0]
    for ax in range(2):
        o = n_p + ax * order
        for k in range(order - 1):
            A[o + k, o + k + 1] = 1.0
        B[o + order - 1, 2 + ax] = 1.0
    M = np.zeros((n + 4, n + 4))
    M[:n, :n], M[:n, n:] = A * fam.T / SUB, B * fam.T / SUB
    E = sla.expm(M)
    Phi, Gam = E[:n, :n], E[:n, n:]
    nb = drive.shape[2]
    x = np.zeros((n, nb))
    pos = [n_p, n_p + order]
    for ax in range(2):
        x[n_p + ax * order: n_p + (ax + 1) * order] = ref0[ax]
    ix, iv = fam.C_p.argmax(axis=1), (fam.C_p @ fam.A_p[0]).argmax(axis=1)
    x[ix], x[iv] = ref0[:, 0], ref0[:, 1]           # on the reference: its position and velocity
    z = np.zeros((fam.A_kd.shape[0], nb))
    periods = drive.shape[0] // SUB
    errs = np.zeros((drive.shape[0] + 1, 2, nb))
    cmds = np.zeros((periods, 2, nb))
    errs[0] = fam.C_p @ x[:n_p] - x[pos]
    for k in range(periods):
        e = fam.C_p @ x[:n_p] - x[pos]
        u = fam.C_k @ z + fam.D_k @ e + (x[[p + 2 for p in pos]] if ff else 0.0)
        cmds[k] = u
        z = fam.A_kd @ z + fam.B_kd @ e
        for s in range(SUB):
            x = Phi @ x + Gam @ np.concatenate([u, drive[k * SUB + s]])
            errs[k * SUB + s + 1] = fam.C_p @ x[:n_p] - x[pos]
    return errs, cmds


def _worst_case(fam, order: int, ff: bool, limit: float) -> float:
    """|e_x| at the end of the input aligned with the sign of the kernel (x axis) that maximises its L1 sum."""
    steps = PERIODS * SUB
    pulses = np.zeros((steps, 2, SUB))
    pulses[np.arange(SUB), 0, np.arange(SUB)] = 1.0
    resp, _ = _raw(fam, order, ff, pulses, np.zeros((2, order, SUB)))   # resp[n, 0, j]: from a pulse at step j
    last = (PERIODS - 1) * SUB
    best = None
    for i in range(SUB):
        n_star = last + i
        q = np.arange(n_star)
        h = resp[n_star - (q // SUB) * SUB, 0, q % SUB]
        if best is None or np.abs(h).sum() > best[0]:
            best = (np.abs(h).sum(), n_star, np.sign(h))
    _, n_star, sign = best
    drive = np.zeros((steps, 2, 1))
    drive[:n_star, 0, 0] = limit * sign
    errs, _ = _raw(fam, order, ff, drive, np.zeros((2, order, 1)))
    return abs(float(errs[n_star, 0, 0]))


def _sinusoids(rng, n: int, derivative: int, limit: float, t: np.ndarray):
    """``n`` random sums of 4 sinusoids per axis whose ``derivative``-th derivative has norm <= limit: that
    derivative on ``t`` (len(t), 2, n) and the lower ones at 0 (2, derivative, n)."""
    om = rng.uniform(0.3, 6.0, (n, 2, 4))
    ph = rng.uniform(0.0, 2 * np.pi, (n, 2, 4))
    c = rng.normal(size=(n, 2, 4))
    c *= (limit / math.sqrt(2) / np.sum(np.abs(c) * om ** derivative, axis=2))[:, :, None]
    top = np.einsum("bak,tbak->tab", c * om ** derivative,
                    np.sin(om[None] * t[:, None, None, None] + ph[None] + derivative * np.pi / 2))
    low = np.stack([np.sum(c * om ** k * np.sin(ph + k * np.pi / 2), axis=2) for k in range(derivative)], axis=1)
    return top, low.transpose(2, 1, 0)   # (t, 2, n), (2, derivative, n)


def test_no_simulated_reference_of_the_class_exceeds_the_bound_and_the_worst_case_nearly_reaches_it(design):
    fam, tb = design
    A, J = tb.accel_limit_m_s2, tb.jerk_limit_m_s3
    rng = np.random.default_rng(7)
    t = (np.arange(PERIODS * SUB) + 0.5) * fam.T / SUB
    # without feedforward: the acceleration is the input (its sub-step values: a member of the class)
    acc, low = _sinusoids(rng, 8, 2, A, t)
    errs, cmds = _raw(fam, 2, False, acc, low)
    assert np.max(np.linalg.norm(acc, axis=1)) <= A
    assert np.max(np.linalg.norm(errs, axis=1)) <= tb.bound_m["no_feedforward"]
    assert np.max(np.linalg.norm(cmds, axis=1)) <= tb.command_bound_m_s2["no_feedforward"]
    worst = _worst_case(fam, 2, False, A)
    assert worst <= tb.per_axis_m["no_feedforward"] <= 1.02 * worst
    # with feedforward: the jerk is the input (the acceleration is continuous, starting at a_d(0) ≠ 0)
    jerk, low = _sinusoids(rng, 8, 3, J, t)
    errs, cmds = _raw(fam, 3, True, jerk, low)
    a_path = low[:, 2][None] + np.cumsum(jerk, axis=0) * fam.T / SUB
    assert np.max(np.linalg.norm(a_path, axis=1)) <= A and np.max(np.linalg.norm(jerk, axis=1)) <= J
    assert np.max(np.linalg.norm(errs, axis=1)) <= tb.bound_m["feedforward"]
    assert np.max(np.linalg.norm(cmds, axis=1)) <= tb.command_bound_m_s2["feedforward"]
    # the jerk part alone (reference starting unaccelerated) is reached by its worst case
    jerk_part = tb.gains["jerk_m_per_m_s3"] * J
    worst = _worst_case(fam, 3, True, J)
    assert worst <= jerk_part <= 1.02 * worst


# ------------------------------------------------------------------------------------------- the class


def test_a_reference_above_the_class_is_reported_outside_and_one_inside_inside(design):
    _, tb = design
    t = np.linspace(0.0, 8.0, 801)
    w = 2 * np.pi / 8.0

    def eight(ax, ay):  # the figure-eight of nniquad.control.references, its derivatives by hand
        x = np.column_stack([ax * np.sin(w * t), ay * np.sin(2 * w * t)])
        v = np.column_stack([ax * w * np.cos(w * t), 2 * ay * w * np.cos(2 * w * t)])
        a = np.column_stack([-ax * w * w * np.sin(w * t), -4 * ay * w * w * np.sin(2 * w * t)])
        j = np.column_stack([-ax * w ** 3 * np.cos(w * t), -8 * ay * w ** 3 * np.cos(2 * w * t)])
        return x, v, a, j

    small = classify_reference(tb, t, *eight(1.0, 0.5))
    assert small.inside == {"no_feedforward": True, "feedforward": True}
    assert small.bound_m["feedforward"] < tb.bound_m["feedforward"]
    big = classify_reference(tb, t, *eight(4.0, 2.0))     # peak acceleration 4 (2w)² > the class's 3 m/s²
    assert big.max_accel_m_s2 > tb.accel_limit_m_s2
    assert big.inside == {"no_feedforward": False, "feedforward": False}
    assert any("acceleration" in r for r in big.reasons["feedforward"])
    # the issue's figure-eight (2 m x 1 m, 8 s) is of the class, but without feedforward its command may reach the
    # tilt limit (outside the linear zone: outside); with feedforward it stays in the zone
    issue = classify_reference(tb, t, *eight(2.0, 1.0))
    assert issue.max_accel_m_s2 <= tb.accel_limit_m_s2 and issue.max_jerk_m_s3 <= tb.jerk_limit_m_s3
    assert issue.inside == {"no_feedforward": False, "feedforward": True}
    assert issue.reasons["no_feedforward"][0].startswith("command up to")
    # jerk estimated from the acceleration's differences when not given
    est = classify_reference(tb, t, *eight(4.0, 2.0)[:3])
    assert est.max_jerk_m_s3 == pytest.approx(big.max_jerk_m_s3, rel=1e-3)


def test_the_full_model_simulator_stays_below_the_bound_of_its_reference(design):
    """The project's simulator (full nonlinear model, motor lag, law in discrete time at 100 Hz, the certificate's
    reference-run settings) flying figure-eights of the class, started on them: the error stays below the bound for
    the reference's own peaks (a nonlinear check of the linear bound; each run is inside the class and the zone)."""
    import dataclasses

    from nniquad.certificates.certificate import reference_run_options
    from nniquad.control.references import FigureEight
    from nniquad.sim import simulate

    _, tb = design
    cert = json.loads(CERT.read_text())
    vehicle, gains, inner = certificate_vehicle(cert), certificate_gains(cert), certificate_inner_loop(cert)
    base = reference_run_options("full", inner, tilt_limit_deg=cert["tilt_limit_deg"], xi0=(0.0, 0.0),
                                 horizon_s=16.0, rate_hz=cert["cascade"]["rate_hz"])
    assert base.controller_sampling == "discrete" and base.motor_lag
    for (ax, ay), ff in (((1.5, 0.75), False), ((2.0, 1.0), True)):
        ref = FigureEight(ax, ay, 8.0)
        x0, v0, _ = ref.sample(0.0)
        run = simulate(vehicle, gains, dataclasses.replace(base, reference=ref, feedforward=ff, xi0=tuple(x0[0]),
                                                           v0=tuple(v0[0])))[0]
        err = float(np.max(np.linalg.norm(run.xy - ref.sample(run.t)[0], axis=1)))
        t = np.linspace(0.0, 16.0, 16001)
        case = "feedforward" if ff else "no_feedforward"
        got = classify_reference(tb, t, *ref.sample(t), ref.jerk(t))
        assert got.inside[case]
        assert err <= got.bound_m[case]
