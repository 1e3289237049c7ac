"""Rotor layouts ('+' and 'x'): the geometry, the mixer and its inverse, the vehicle field, the hover linearisation,
and an X-frame vehicle that certifies and flies.

References: the mixers derived here by hand from the rotor positions (below), the Crazyflie firmware's own 'x'
allocation (its signs transcribed), the '+' vehicle's linearised closed loop, and the certificate's own check.
"""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import sympy as sp

from nniquad.analysis.cascade import box_certificate as RC
from nniquad.analysis.linearised_cascade import linearise_cascade
from nniquad.certificates import build_certificate, verify_certificate
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CertificateCheckError, VehicleError
from nniquad.model import numeric as N
from nniquad.model import symbolic as S
from nniquad.laws.nni import Gains
from nniquad.model.vehicle import PAPER_VEHICLE, load_vehicle, vehicle_from_mapping, vehicle_to_toml
from nniquad.sim import SimOptions, simulate
from nniquad.tuning.vehicle_limits import attitude_accel_headroom

VX = PAPER_VEHICLE.with_(frame="x")
# the certified test design of tests/test_certificate.py (found by `nniquad tune --model full` for the '+' vehicle)
GAINS = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56, attitude_zeta=1.132, attitude_accel_limit_rad_s2=31.14)
IRIS_X = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "vehicles" / "iris_x.toml"


def _hand_mixer(frame: str) -> sp.Matrix:
    """The mixer written out from the rotor positions: thrust b w² along -z_B at r_i gives the roll torque
    ``-b y_i w²`` and the pitch torque ``b x_i w²``; a rotor spinning about ±z_B gives ``∓d w²`` of yaw.

    '+': rotors at l (1, 0), (0, 1), (-1, 0), (0, -1), spins +, -, +, -.  'x': at (l/√2)(1, 1), (-1, 1),
    (-1, -1), (1, -1) (front-right, back-right, back-left, front-left), spins -, +, -, +.
    """
    s = S.symbols()
    b, d, l = s.b, s.d, s.l
    if frame == "+":
        xy, spins = [(l, 0), (0, l), (-l, 0), (0, -l)], [1, -1, 1, -1]
    else:
        a = l / sp.sqrt(2)
        xy, spins = [(a, a), (-a, a), (-a, -a), (a, -a)], [-1, 1, -1, 1]
    return sp.Matrix([[b] * 4, [-b * y for _, y in xy], [b * x for x, _ in xy], [-sp_ * d for sp_ in spins]])


@pytest.mark.parametrize("frame", ["+", "x"])
def test_mixer_is_the_hand_derivation_exactly(frame):
    assert sp.simplify(S.mixer_matrix(frame) - _hand_mixer(frame)) == sp.zeros(4, 4)
    # the allocation is its exact inverse, and every layout spreads the collective evenly
    assert sp.simplify(S.allocation_matrix(frame) * S.mixer_matrix(frame) / S.symbols().b) == sp.eye(4)
    assert list(S.allocation_matrix(frame)[:, 0]) == [sp.Rational(1, 4)] * 4


def test_x_mixer_closed_form_numerically_and_in_the_generated_code():
    b, d, l = VX.b, VX.d, VX.l
    a = l * b / math.sqrt(2)
    hand = np.array([[b, b, b, b], [-a, -a, a, a], [a, -a, -a, a], [d, -d, d, -d]])
    np.testing.assert_allclose(N.mixer_numpy(VX), hand, rtol=1e-15)
    w = np.array([600.0, 610.0, 620.0, 630.0])
    u, om = N.mixer_function()(w, N.param_vector(VX))
    # the torques are differences of terms |hand| w² large: round-off is relative to those
    np.testing.assert_allclose(np.array(u).ravel(), hand @ w**2, rtol=0, atol=1e-14 * np.max(np.abs(hand) @ w**2))
    assert float(om) == pytest.approx(-600 + 610 - 620 + 630)
    # the '+' vehicle's generated mixer is not the 'x' one: the frame is in the parameter vector
    u_plus, om_plus = N.mixer_function()(w, N.param_vector(PAPER_VEHICLE))
    assert abs(float(u_plus[1]) - float(u[1])) > 1e-3 * abs(float(u[1])) and float(om_plus) == -float(om)


def test_x_allocation_is_the_crazyflie_firmwares():
    """bitcraze/crazyflie-firmware power_distribution_quadrotor.c, powerDistributionForceTorque (body FLU):
    ``F_i = T/4 + s_r τx/(4a) + s_p τy/(4a) + s_y τz/(4k)`` with ``a = l/√2``, ``k = d/b`` (THRUST2TORQUE) and the
    signs (s_r, s_p, s_y) = M1 (-, -, -), M2 (-, +, +), M3 (+, +, -), M4 (+, -, +).  FRD: τx = τ_φ, τy = -τ_θ,
    τz = -τ_ψ."""
    signs = np.array([[-1, -1, -1], [-1, 1, 1], [1, 1, -1], [1, -1, 1]], float)
    a, k = VX.l / math.sqrt(2), VX.d / VX.b
    frd = np.diag([1.0, -1.0, -1.0])  # (τ_φ, τ_θ, τ_ψ) -> (τx, τy, τz)
    cf = np.hstack([np.full((4, 1), 0.25), (signs / (4 * np.array([a, a, k]))) @ frd])
    np.testing.assert_allclose(N.allocation_numpy(VX), cf, rtol=1e-14)


def test_rotor_modes_are_orthonormal_mixer_rows():
    for frame in ("+", "x"):
        R = N.rotor_modes(frame)
        np.testing.assert_allclose(R @ R.T, np.eye(4), atol=1e-15)
    # '+': roll from w4 - w2, pitch from w1 - w3; 'x': roll from the left pair minus the right pair
    h = 1 / math.sqrt(2)
    np.testing.assert_allclose(N.rotor_modes("+")[1:3], [[0, -h, 0, h], [h, 0, -h, 0]], atol=1e-15)
    np.testing.assert_allclose(N.rotor_modes("x")[1:3], [[-.5, -.5, .5, .5], [.5, -.5, -.5, .5]], atol=1e-15)


def test_the_frame_field(tmp_path):
    assert PAPER_VEHICLE.frame == "+" and "frame" not in PAPER_VEHICLE.as_dict()  # records before frames read the same
    assert vehicle_from_mapping({**PAPER_VEHICLE.as_dict(), "frame": "X"}).frame == "x"
    assert VX.as_dict()["frame"] == "x"
    with pytest.raises(VehicleError, match=r"^vehicle: vehicle field 'frame' must be one of '\+', 'x' \(rotor layout\), "
                                           r"got 'h'$"):
        PAPER_VEHICLE.with_(frame="h")
    with pytest.raises(VehicleError, match="frame"):
        PAPER_VEHICLE.with_(frame=4)
    path = tmp_path / "v.toml"
    path.write_text(vehicle_to_toml(VX))
    assert load_vehicle(path) == VX
    iris = load_vehicle(IRIS_X)
    assert iris.frame == "x" and iris.frame_index == 1


def test_x_hover_linearisation():
    """At hover every rotor turns at the same speed w_h in both layouts.  Raising the left pair by δ and lowering
    the right pair by δ gives the roll torque ``4 (l b/√2) 2 w_h δ`` on 'x' (four rotors, arm l/√2), against
    ``2 l b 2 w_h δ`` on '+' (two rotors, arm l): √2 times more.  The torque headroom of the tuner scales alike."""
    w_h = VX.hover_rotor_speed()
    w = ca.SX.sym("w", 4)
    mix = N.mixer_function()
    for v, left, right, expected in ((VX, [2, 3], [0, 1], 4 * VX.l * VX.b / math.sqrt(2) * 2 * w_h),
                                     (PAPER_VEHICLE, [3], [1], 2 * VX.l * VX.b * 2 * w_h)):
        u, _ = mix(w, N.param_vector(v))
        jac = np.asarray(ca.Function("j", [w], [ca.jacobian(u, w)])(np.full(4, w_h)), float)
        delta = np.zeros(4)
        delta[left], delta[right] = 1.0, -1.0
        np.testing.assert_allclose(jac @ delta, [0.0, expected, 0.0, jac[3] @ delta], rtol=1e-13, atol=1e-12)
    assert attitude_accel_headroom(VX, 30.0) == pytest.approx(math.sqrt(2) * attitude_accel_headroom(PAPER_VEHICLE, 30.0),
                                                              rel=1e-13)
    # the closed loop at hover is the same: the allocation inverts each layout's mixer exactly, so the linearised
    # cascade (rigid body, motors, inner loops, NNI law) has the '+' vehicle's spectrum
    ev = [np.sort_complex(np.linalg.eigvals(linearise_cascade(v, GAINS, INNER).A)) for v in (PAPER_VEHICLE, VX)]
    np.testing.assert_allclose(ev[1], ev[0], rtol=1e-7, atol=1e-7)


def test_x_cascade_splits_in_its_own_rotor_modes():
    """The cascade section's subsystems decouple in the 'x' rotor modes, and do not in the '+' ones."""
    from dataclasses import replace

    fam = RC.sampled_family(VX, GAINS, INNER, RC.ParameterBox.monte_carlo_default().scaled(0.1).vertices()[:2])
    assert fam.frame == "x" and RC.coupling(fam) < RC.COUPLING_TOL
    assert RC.coupling(replace(fam, frame="+")) > 1e-3


def test_an_x_frame_vehicle_certifies_and_flies():
    """The test design certified on the paper's vehicle as an X frame: the certificate states the frame in its
    vehicle section (and digest), verifies, and its full-model reference run settles; an X frame flown by the
    simulator settles within 2 % of the '+' vehicle (the same loop at hover, more roll/pitch authority)."""
    cert = build_certificate(VX, GAINS, inner=INNER, model="full", cascade=False).to_json()
    assert cert["vehicle"]["frame"] == "x" and cert["start_certified"]
    assert verify_certificate(cert).ok
    settle = cert["performance"]["full"]["settling_s"]
    assert settle is not None and math.isfinite(settle)
    tampered = {**cert, "vehicle": {k: v for k, v in cert["vehicle"].items() if k != "frame"}}  # now a '+' vehicle
    with pytest.raises(CertificateCheckError, match="digest mismatch"):
        verify_certificate(tampered)
    runs = [simulate(v, GAINS, SimOptions(model="full", horizon_s=12.0, motor_lag=True, inner=INNER))
            for v in (PAPER_VEHICLE, VX)]
    t_plus, t_x = (float(r.settling_s[0]) for r in runs)
    assert t_x == pytest.approx(t_plus, rel=0.02)
