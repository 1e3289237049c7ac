"""The RotorPy adapter (:mod:`nniquad.integrations.rotorpy`) against RotorPy's own physics and the project's simulator.

RotorPy (a second simulator, written independently) integrates the vehicle; the
adapter only runs the certificate's discrete law.  The flights compare RotorPy's
2 % settling time with the project's own ``full`` run of the same certificate.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from nniquad.certificates.certificate import PERFORMANCE_OUTPUT_DT_S, read_certificate
from nniquad.certificates.export import certified_rate_hz, controller_from_certificate
from nniquad.errors import NniquadError
from nniquad.model.layout import PARAM_NAMES
from nniquad.model.vehicle import Vehicle
from nniquad.sim import SimOptions, simulate

rotorpy_multirotor = pytest.importorskip("rotorpy.vehicles.multirotor", reason="RotorPy is a dev dependency")

from nniquad.integrations.rotorpy import (  # noqa: E402  (after the skip: the module is RotorPy's adapter)
    RotorPyController,
    between_frames,
    fly_certificate,
    quad_params,
)

DATA = Path(__file__).resolve().parents[1] / "notebooks" / "data"
NNI = DATA / "cascade_model_certificate.json"
SNI2 = DATA / "sni2_cascade_certificate.json"
#: The sni2 certificate flown through RotorPy's own loop (the one above swings near the tilt limit, where RotorPy's
#: SO(3) attitude error and the project's Euler-angle error part: about 5 % in settling, docs/integrations.md).
SNI2_PAPER = DATA / "designs" / "sni2_paper_certificate.json"
#: Flight length [s]: the shortest that shows settling (the project's run of this length gives the certificate's
#: settling time of its 20 s run, asserted below).
HORIZON_S = 2.0
#: RotorPy's step rate [Hz]: five steps per control period of the certificates (100 Hz).
SIM_RATE_HZ = 500.0
#: The match the issue asks for: settling times within 2 % of each other.
SETTLING_RTOL = 0.02
HAS_FRAME = "frame" in {f.name for f in dataclasses.fields(Vehicle)}


def _rotorpy_wrench(vehicle: Vehicle, rotor_speeds: np.ndarray) -> np.ndarray:
    """RotorPy's own thrust and body moment (FLU) at hover attitude, no motion: ``(T, M_x, M_y, M_z)``."""
    mr = rotorpy_multirotor.Multirotor(quad_params(vehicle), aero=False)
    force, moment = mr.compute_body_wrench(np.zeros(3), rotor_speeds, np.zeros(3))
    return np.concatenate([[force[2]], moment])


def _project_wrench(vehicle: Vehicle, rotor_speeds: np.ndarray, frame: str = "+") -> np.ndarray:
    """The project's ``(u1, τ)`` (FRD) from its symbolic mixer."""
    from nniquad.model import symbolic as S  # sympy only for this check

    A = S.mixer_matrix() if frame == "+" else S.mixer_matrix(frame)
    values = {sym: getattr(vehicle, name) for sym, name in zip(S.symbols().params, PARAM_NAMES)}
    return np.array(A.subs(values), dtype=float) @ rotor_speeds**2


def _check_wrench(vehicle: Vehicle, frame: str = "+") -> None:
    rng = np.random.default_rng(46)
    for _ in range(5):
        w = rng.uniform(0.3, 1.0, 4) * vehicle.omega_max
        ours = _project_wrench(vehicle, w, frame)
        theirs = _rotorpy_wrench(vehicle, w)
        # same thrust; the torque's FRD components are (x, -y, -z) of RotorPy's FLU ones
        np.testing.assert_allclose(theirs, np.concatenate([[ours[0]], between_frames(ours[1:])]),
                                   rtol=1e-12, atol=1e-12 * abs(ours[0]))


def test_frames_conversion_is_the_rotation_by_pi_about_north():
    # a vector: (north, east, down) is (x, -y, -z) in RotorPy's z-up world
    np.testing.assert_array_equal(between_frames([1.0, 2.0, 3.0]), [1.0, -2.0, -3.0])
    np.testing.assert_array_equal(between_frames(between_frames([1.0, 2.0, 3.0])), [1.0, 2.0, 3.0])
    # an attitude: ZYX angles (φ, θ, ψ) in NED are (φ, -θ, -ψ) in the z-up frame (nniquad.model.symbolic)
    phi, theta, psi = 0.3, -0.2, 1.1
    R_ned = Rotation.from_euler("ZYX", [psi, theta, phi]).as_matrix()
    R_up = Rotation.from_euler("ZYX", [-psi, -theta, phi]).as_matrix()
    np.testing.assert_allclose(between_frames(R_ned), R_up, atol=1e-15)
    # physics: nose up (θ > 0 in NED) tilts the thrust backwards, an acceleration to the south; in RotorPy the
    # thrust is along the body's +z (FLU), and its x (north) component is then -sin θ
    R_up = between_frames(Rotation.from_euler("ZYX", [0.0, 0.4, 0.0]).as_matrix())
    assert R_up[0, 2] == pytest.approx(-math.sin(0.4), abs=1e-15)


def test_quad_params_give_rotorpy_the_projects_rotor_wrench():
    _check_wrench(read_certificate(NNI).vehicle)


@pytest.mark.skipif(not HAS_FRAME, reason="Vehicle has no 'frame' field yet (X frames come with another branch)")
def test_x_frame_wrench_and_flight():
    cert = read_certificate(NNI)
    vehicle = dataclasses.replace(cert.vehicle, frame="x")
    _check_wrench(vehicle, "x")
    cert_x = dataclasses.replace(cert, vehicle=vehicle)
    _match_project(cert_x, "rotorpy")


def test_adapter_runs_the_discrete_law_from_position_only():
    cert = read_certificate(SNI2)
    rate = certified_rate_hz(cert)
    law = controller_from_certificate(cert, rate)
    ctrl = RotorPyController(cert)
    blind = RotorPyController(cert)  # sees the same states with zero horizontal velocity
    rng = np.random.default_rng(7)
    dt = law.T / 5
    z, held = None, None
    for k in range(40):
        north, east = rng.uniform(-3.0, 3.0, 2)
        if k % 5 == 0:  # yaw drawn once per control period: the held tilt setpoints are relative to it
            psi = rng.uniform(-0.5, 0.5)  # NED yaw
        q = Rotation.from_euler("z", -psi).as_quat()  # the same yaw in RotorPy's z-up frame
        state = {"x": np.array([north, -east, 0.0]), "v": np.array([*rng.uniform(-5, 5, 2), 0.0]), "q": q,
                 "w": np.zeros(3)}
        flat = {"x": np.zeros(3), "yaw": -psi}
        cmd = ctrl.update(k * dt, state, flat)
        other = blind.update(k * dt, {**state, "v": np.zeros(3)}, flat)
        for key in cmd:
            np.testing.assert_array_equal(cmd[key], other[key])
        if k % 5 == 0:  # a sample instant: the law steps on (north, east) at the measured yaw, a_z = 0 at z = 0
            xi = np.array([north, east])
            z = law.start(xi) if z is None else z
            z, a_h, _ = law.step(z, xi, psi, 0.0)
            held = a_h
        # the commanded thrust direction realises the held a_h: specific force (a_x, a_y, -g) in NED
        thrust_up = Rotation.from_quat(cmd["cmd_q"]).as_matrix()[:, 2]
        thrust_ned = between_frames(thrust_up)
        np.testing.assert_allclose(thrust_ned[:2] / -thrust_ned[2], held / cert.vehicle.g, rtol=1e-12, atol=1e-12)


def _project_settling(cert) -> float:
    """The project's ``full`` run of the certificate, its settings built from the certificate's fields: the
    certificate's vehicle, inner loop, tilt limit and start, motor lag on, the position sampled at the certified
    rate and the law in discrete time (``performance.full`` of :func:`nniquad.certificates.build.performance_runs`)."""
    opts = SimOptions(model="full", horizon_s=HORIZON_S, output_dt_s=PERFORMANCE_OUTPUT_DT_S,
                      tilt_limit_deg=cert.tilt_limit_deg, xi0=tuple(cert.xi0_m), motor_lag=True, inner=cert.inner_loop,
                      controller_sampling="discrete", noise_rate_hz=certified_rate_hz(cert))
    return simulate(cert.vehicle, cert.gains, opts)[0].metrics().settling_s


def _match_project(cert, attitude: str) -> tuple[float, float]:
    ours = _project_settling(cert)
    flight = fly_certificate(cert, horizon_s=HORIZON_S, attitude=attitude, sim_rate_hz=SIM_RATE_HZ)
    assert flight.settling_s is not None, "the RotorPy flight did not settle"
    assert flight.settling_s == pytest.approx(ours, rel=SETTLING_RTOL)
    return ours, flight.settling_s


@pytest.mark.parametrize("path", [NNI, SNI2_PAPER], ids=["nni", "sni2"])
def test_rotorpy_flight_settles_as_the_projects_run(path):
    """Both laws through RotorPy's own attitude loop at the certificate's bandwidth and damping.  The project's short
    run gives the certificate's stated settling time (so the horizon shows settling)."""
    cert = read_certificate(path)
    ours, _ = _match_project(cert, "rotorpy")
    assert ours == pytest.approx(cert.body()["performance"]["full"]["settling_s"], rel=1e-9)


def test_rotorpy_default_attitude_gains_break_the_match():
    """The inner-loop requirement: RotorPy's default attitude gains (a lag of 0.12 s) settle the NNI law far later."""
    cert = read_certificate(NNI)
    ours = _project_settling(cert)
    flight = fly_certificate(cert, horizon_s=HORIZON_S, attitude="rotorpy-default", sim_rate_hz=SIM_RATE_HZ)
    assert flight.settling_s is None or flight.settling_s > (1 + 10 * SETTLING_RTOL) * ours


def test_take_over_at_any_time_and_refuse_a_missed_sample():
    cert = read_certificate(NNI)
    ctrl = RotorPyController(cert)
    T = ctrl.law.T
    state = {"x": np.array([1.0, 0.5, 0.0]), "v": np.zeros(3), "q": np.array([0.0, 0.0, 0.0, 1.0]), "w": np.zeros(3)}
    flat = {"x": np.zeros(3), "yaw": 0.0}
    first = ctrl.update(7.0, state, flat)["cmd_q"]  # takes over at t = 7 s: samples at 7, 7 + T, ...
    moved = {**state, "x": np.array([-1.0, 0.0, 0.0])}
    np.testing.assert_array_equal(ctrl.update(7.0 + T / 2, moved, flat)["cmd_q"], first)  # held between samples
    assert not np.array_equal(ctrl.update(7.0 + T, moved, flat)["cmd_q"], first)
    with pytest.raises(NniquadError, match="at least at the control rate"):
        ctrl.update(7.0 + 3 * T, moved, flat)


def test_a_missing_rotorpy_is_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "rotorpy", None)
    with pytest.raises(NniquadError, match=r"pip install 'rotorpy==3\.0\.0'"):
        fly_certificate(read_certificate(NNI), horizon_s=1.0)


def test_certificate_attitude_mode_commands_rotorpys_own_loop_near_hover():
    """The ``certificate`` mode's torques (the project's attitude law, moved to the FLU body) and RotorPy's own
    ``cmd_ctatt`` loop at the certificate's gains agree near hover in roll and pitch (the yaw hold has its own gains in
    the project, RotorPy's one pair in RotorPy): the same rotor speeds from RotorPy's allocation."""
    cert = read_certificate(SNI2)
    ours, theirs = RotorPyController(cert, attitude="certificate"), RotorPyController(cert, attitude="rotorpy")
    params = ours.quad_params()
    ctbm = rotorpy_multirotor.Multirotor(params, control_abstraction=ours.control_abstraction, aero=False)
    ctatt = rotorpy_multirotor.Multirotor(params, control_abstraction=theirs.control_abstraction, aero=False)
    hover = cert.vehicle.hover_rotor_speed()
    rng = np.random.default_rng(11)
    for _ in range(5):
        small = 1e-4
        state = {"x": np.array([*rng.uniform(-small, small, 2), 0.0]), "v": np.zeros(3),
                 "q": Rotation.from_rotvec([*rng.uniform(-small, small, 2), 0.0]).as_quat(),
                 "w": np.array([*rng.uniform(-small, small, 2), 0.0]), "rotor_speeds": np.full(4, hover),
                 "wind": np.zeros(3)}
        flat = {"x": np.zeros(3), "yaw": 0.0}
        ours.reset(), theirs.reset()
        a = ctbm.get_cmd_motor_speeds(state, ours.update(0.0, state, flat))
        b = ctatt.get_cmd_motor_speeds(state, theirs.update(0.0, state, flat))
        spread = np.ptp(a)  # the attitude part of the command; the collective is the same formula in both
        assert spread > 0
        np.testing.assert_allclose(a - a.mean(), b - b.mean(), rtol=0, atol=1e-3 * spread)
