"""Fly a certificate's discrete law in RotorPy (https://github.com/spencerfolk/rotorpy, tested with 3.0.0).

:class:`RotorPyController` has RotorPy's controller interface,
``update(t, state, flat_output) -> dict``.  It runs the certificate's discrete
law (:func:`nniquad.certificates.export.controller_from_certificate`, the step
``nniquad export`` writes as C) at the certificate's rate from the *position
only*, holds its tilt setpoints between samples, closes the altitude loop of
:mod:`nniquad.control.inner_loops` (item 1, with the vertical velocity) and hands
an attitude and a collective thrust to an attitude loop.  RotorPy's horizontal
velocity is never read.

The inner loop
--------------
The certificate holds only for an attitude loop with the lag it assumed: near
hover each roll/pitch axis is ``ω_a² / (s² + 2 ζ_a ω_a s + ω_a²)``
(``inner_loop.attitude_wn_rad_s``, ``inner_loop.attitude_zeta``; effective delay
``2 ζ_a / ω_a``).  RotorPy's own attitude loop (control abstraction
``cmd_ctatt``, in ``rotorpy/vehicles/multirotor.py``) is the SO(3) PD

.. math:: M = J(-k_p e_R - k_d \\omega) + \\omega \\times J \\omega,
          \\qquad e_R = \\tfrac12 (R_d^T R - R^T R_d)^\\vee,

whose small-angle form per axis is ``θ'' = -k_p (θ - θ_d) - k_d θ'``, the same
second-order lag with ``k_p = ω_a²`` and ``k_d = 2 ζ_a ω_a``
(:func:`attitude_gains`; ``quad_params['kp_att']``, ``quad_params['kd_att']``).
Only this linear part matches the project's loop: RotorPy uses one gain pair
for all three axes (the yaw hold ``ω_ψ, ζ_ψ`` is not set), its error is the
SO(3) one rather than Euler-angle differences, it has no square-root shaping of
large errors (``attitude_accel_limit_rad_s2``), its allocation clips rotor
speeds instead of keeping the collective first, and its rotors have no inertia.
Without the two keys RotorPy takes its defaults ``k_p = 3000``, ``k_d = 360``,
a lag ``k_d/k_p`` = 0.12 s; the certificate does not cover that loop.

The attitude modes (:data:`ATTITUDE_MODES`):

``"rotorpy"``
    RotorPy's attitude loop at the certificate's ``ω_a, ζ_a`` (``cmd_ctatt``).
``"rotorpy-default"``
    RotorPy's attitude loop at its default gains (``cmd_ctatt``): not certified.
``"certificate"``
    The project's own attitude law (:func:`nniquad.control.inner_loops.attitude_torques`:
    Euler-angle PD with the square-root shaping, and the yaw hold) run here, and
    its torques handed to RotorPy (``cmd_ctbm``): the loop the certificate's
    ``performance.full`` run was measured with.

Frames
------
The law is written in NED with an FRD body (:mod:`nniquad.model.symbolic`).
RotorPy's world is z-up and its body z axis points along the thrust (FLU).
:func:`between_frames` is the one conversion, the rotation by π about north
(:func:`nniquad.model.symbolic.zup_vector`): RotorPy's ``(x, y, z)`` is
``(north, -east, -down)``.  It is its own inverse.

RotorPy is a test dependency (the ``dev`` extra), imported only where needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np
from scipy.spatial.transform import Rotation

from nniquad.certificates.certificate import Certificate
from nniquad.certificates.export import controller_from_certificate, export_rate_hz
from nniquad.config import DT_S
from nniquad.control import inner_loops as IL
from nniquad.errors import NniquadError
from nniquad.model.layout import PARAM_NAMES
from nniquad.model.numeric import rotation_function
from nniquad.sim.metrics import overshoot_pct, settling_time

if TYPE_CHECKING:
    from nniquad.control.inner_gains import InnerLoopGains
    from nniquad.model.vehicle import Vehicle

__all__ = ["ATTITUDE_MODES", "RotorPyController", "RotorPyFlight", "attitude_gains", "between_frames",
           "fly_certificate", "quad_params", "rotor_layout"]

#: The attitude loops the adapter can fly with (module docstring).
ATTITUDE_MODES: dict[str, str] = {
    "rotorpy": "RotorPy's SO(3) attitude loop at the certificate's bandwidth and damping",
    "rotorpy-default": "RotorPy's SO(3) attitude loop at its default gains (not certified)",
    "certificate": "the project's attitude law, RotorPy given body moments",
}


def _rotorpy():
    """The ``rotorpy`` package, or a one-line error naming the install."""
    try:
        import rotorpy  # an optional test dependency: only a RotorPy flight needs it
    except ImportError:
        raise NniquadError("flying in RotorPy needs RotorPy: pip install 'rotorpy==3.0.0' "
                           "(the dev extra has it)") from None
    return rotorpy


def between_frames(a: Any) -> np.ndarray:
    """A vector or rotation matrix moved between NED/FRD and RotorPy's z-up world / FLU body.

    The two frames differ by the rotation ``F = diag(1, -1, -1)`` (π about north,
    :func:`nniquad.model.symbolic.zup_vector`): a vector maps to ``F v``, a
    body-to-world rotation to ``F R F``.  ``F`` is its own inverse, so the same
    call converts either way.

    Parameters
    ----------
    a
        A 3-vector or a 3x3 rotation matrix.
    """
    a = np.asarray(a, dtype=float)
    flip = _flip()
    return flip @ a @ flip if a.shape == (3, 3) else flip @ a


@lru_cache(maxsize=1)
def _flip() -> np.ndarray:
    """``F`` of :func:`between_frames`, from the symbolic model's own z-up map."""
    import sympy as sp
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and importing nniquad needs none

    return np.array(S.zup_vector(sp.eye(3)), dtype=float)


def rotor_layout(vehicle: "Vehicle") -> tuple[np.ndarray, np.ndarray]:
    """Rotor positions (4, 3) [m] in the body FRD frame and spin signs, from the symbolic geometry.

    :func:`nniquad.model.symbolic.rotor_geometry` of the vehicle's frame
    (``vehicle.frame``, '+' when the field is absent), evaluated at its parameters.
    """
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and importing nniquad needs none

    frame = getattr(vehicle, "frame", "+")
    positions, spins = S.rotor_geometry() if frame == "+" else S.rotor_geometry(frame)
    values = {sym: getattr(vehicle, name) for sym, name in zip(S.symbols().params, PARAM_NAMES)}
    pos = np.array([[float(c.subs(values)) for c in p] for p in positions])
    return pos, np.array(spins, dtype=int)


def attitude_gains(inner: "InnerLoopGains") -> dict[str, float]:
    """RotorPy's attitude gains for an inner loop: ``kp_att = ω_a²``, ``kd_att = 2 ζ_a ω_a`` (module docstring).

    Parameters
    ----------
    inner
        The certificate's inner loop.
    """
    wn, zeta = inner.attitude_wn_rad_s, inner.attitude_zeta
    return {"kp_att": wn**2, "kd_att": 2.0 * zeta * wn}


def quad_params(vehicle: "Vehicle", inner: "InnerLoopGains | None" = None) -> dict[str, Any]:
    """RotorPy's ``quad_params`` of a vehicle, aerodynamics off.

    Mass and inertia as they are; rotors from :func:`rotor_layout` moved to the
    FLU body (:func:`between_frames`); ``k_eta = b``, ``k_m = d``; rotor speeds in
    ``[0, ω_max]``; ``tau_m`` the motor time constant.  RotorPy's yaw moment of rotor
    ``i`` is ``rotor_directions[i] k_m ω_i²`` about its body z (up); the project's
    drag reaction is ``-spin_i d ω_i²`` about the FRD z (down), the same torque, so
    the directions are the spins.

    Parameters
    ----------
    vehicle
        The vehicle.
    inner
        The inner loop whose ``ω_a, ζ_a`` set RotorPy's attitude gains
        (:func:`attitude_gains`); ``None``: RotorPy's defaults.
    """
    pos, spins = rotor_layout(vehicle)
    params: dict[str, Any] = {
        "mass": vehicle.m, "Ixx": vehicle.Jx, "Iyy": vehicle.Jy, "Izz": vehicle.Jz, "Ixy": 0.0, "Ixz": 0.0, "Iyz": 0.0,
        "num_rotors": len(spins), "rotor_pos": {f"r{i + 1}": between_frames(p) for i, p in enumerate(pos)},
        "rotor_directions": spins.copy(),
        "c_Dx": 0.0, "c_Dy": 0.0, "c_Dz": 0.0, "k_d": 0.0, "k_z": 0.0, "k_h": 0.0, "k_flap": 0.0,
        "k_eta": vehicle.b, "k_m": vehicle.d, "tau_m": vehicle.tau_motor, "motor_noise_std": 0.0,
        "rotor_speed_min": 0.0, "rotor_speed_max": vehicle.omega_max,
    }
    if inner is not None:
        params.update(attitude_gains(inner))
    return params


def _typed(cert: "Certificate | Mapping[str, Any]") -> "Certificate":
    """The certificate typed (a mapping is form- and field-checked by :meth:`Certificate.from_json`)."""
    return cert if isinstance(cert, Certificate) else Certificate.from_json(cert)


class RotorPyController:
    """A certificate's discrete law as a RotorPy controller (module docstring).

    Parameters
    ----------
    cert
        A certificate (or its JSON mapping).
    attitude
        One of :data:`ATTITUDE_MODES`.
    rate_hz
        Control rate [Hz]; default the rate the certificate certifies.

    Attributes
    ----------
    law : nniquad.control.discrete.DiscreteLaw
        The discrete law that runs.
    control_abstraction : str
        The abstraction RotorPy's ``Multirotor`` must be built with.
    """

    def __init__(self, cert: "Certificate | Mapping[str, Any]", *, attitude: str = "rotorpy",
                 rate_hz: float | None = None) -> None:
        if attitude not in ATTITUDE_MODES:
            raise NniquadError(f"unknown attitude mode {attitude!r} (choose one of {', '.join(ATTITUDE_MODES)})")
        self.cert = _typed(cert)
        self.attitude = attitude
        rate = export_rate_hz(self.cert, rate_hz)
        self.law = controller_from_certificate(self.cert, rate)
        self.vehicle, self.inner = self.cert.vehicle, self.cert.inner_loop
        self.control_abstraction = "cmd_ctbm" if attitude == "certificate" else "cmd_ctatt"
        self.reset()

    def quad_params(self) -> dict[str, Any]:
        """RotorPy's ``quad_params`` of the certificate's vehicle, attitude gains as the mode says."""
        return quad_params(self.vehicle, None if self.attitude == "rotorpy-default" else self.inner)

    def reset(self) -> None:
        """Forget the law's state: the next :meth:`update` takes over as at start-up."""
        self._z: np.ndarray | None = None
        self._next_sample_s = 0.0
        self._tilt_sp = np.zeros(2)
        self._z_int = 0.0
        self._t_last: float | None = None

    def update(self, t: float, state: Mapping[str, Any], flat_output: Mapping[str, Any]) -> dict[str, Any]:
        """RotorPy's controller call: the commands for ``state`` at time ``t`` [s].

        The first call takes over (the law's start state for the measured
        position); the law then steps on the first call at or after each
        sample instant, which RotorPy must reach at least once per period.
        Reads ``state['x']``, ``state['q']``, ``state['w']`` and the vertical
        component of ``state['v']``; the setpoint is ``flat_output['x']`` and
        ``flat_output['yaw']``.
        """
        R = between_frames(_rotation(state["q"]))
        err = between_frames(np.asarray(state["x"], float) - np.asarray(flat_output["x"], float))
        v_down = -float(state["v"][2])  # the altitude loop's vertical speed; the horizontal velocity is not read
        psi = math.atan2(R[1, 0], R[0, 0])
        if self._t_last is not None:
            self._z_int += err[2] * (t - self._t_last)
        self._t_last = t
        g = self.vehicle.g
        a_z = float(IL.altitude_command(err[2], v_down, self._z_int, self.inner.altitude_wn_rad_s))
        T = self.law.T
        if self._z is None:  # take-over: the law's start state, and its sample grid from now
            self._z, self._next_sample_s = self.law.start(err[:2]), t
        if t >= self._next_sample_s - 1e-9 * T:
            if t >= self._next_sample_s + T * (1 - 1e-9):
                raise NniquadError(f"RotorPy called the controller {t - self._next_sample_s + T:.6g} s after its last "
                                   f"sample: step RotorPy at least at the control rate ({1 / T:g} Hz)")
            self._z, _, self._tilt_sp = self.law.step(self._z, err[:2], psi, a_z)
            self._next_sample_s += T
        # the collective of inner_loops item 2: the hover thrust of g_z, tilt-compensated (capped)
        g_z = float(IL.vertical_specific_force(g, a_z))
        thrust = float(IL.collective_thrust(self.vehicle.m, g_z, R[2, 2]))
        psi_d = -float(flat_output.get("yaw", 0.0))
        phi_d, theta_d = self._tilt_sp
        if self.attitude == "certificate":
            return {"cmd_thrust": thrust, "cmd_moment": self._torques(R, state["w"], psi_d)}
        R_d = np.asarray(rotation_function()([phi_d, theta_d, psi_d])[0], dtype=float)
        return {"cmd_thrust": thrust, "cmd_q": _quaternion(between_frames(R_d))}

    def _torques(self, R: np.ndarray, w_flu: Any, psi_d: float) -> np.ndarray:
        """The project's attitude torques (FRD) for the held setpoints, moved to the FLU body."""
        psi, theta, phi = Rotation.from_matrix(R).as_euler("ZYX")
        inner, v = self.inner, self.vehicle
        tau = IL.attitude_torques(np.array([phi, theta, math.remainder(psi - psi_d, 2 * math.pi)]), between_frames(w_flu), self._tilt_sp[0],
                                  self._tilt_sp[1], (v.Jx, v.Jy, v.Jz), inner.attitude_wn_rad_s, inner.attitude_zeta,
                                  inner.yaw_wn_rad_s, inner.yaw_zeta, inner.attitude_gain_scale,
                                  inner.attitude_accel_limit_rad_s2)
        return between_frames(np.array(tau, dtype=float).ravel())


def _rotation(q: Any) -> np.ndarray:
    """RotorPy's attitude quaternion ``[i, j, k, w]`` as a body-to-world matrix."""
    return Rotation.from_quat(np.asarray(q, float)).as_matrix()


def _quaternion(R: np.ndarray) -> np.ndarray:
    return Rotation.from_matrix(R).as_quat()


@dataclass(frozen=True)
class RotorPyFlight:
    """A RotorPy flight of a certificate.

    Attributes
    ----------
    t : ndarray (N,)
        Times [s].
    xy : ndarray (N, 2)
        Horizontal position relative to the setpoint, NED (north, east) [m].
    """

    t: np.ndarray
    xy: np.ndarray

    @property
    def settling_s(self) -> float | None:
        """The 2 % settling time (:func:`nniquad.sim.metrics.settling_time`), ``None`` if it did not settle."""
        return settling_time(self.t, self.xy)

    @property
    def overshoot_pct(self) -> float:
        """The overshoot past the setpoint along the start direction [%] (:func:`nniquad.sim.metrics.overshoot_pct`)."""
        return overshoot_pct(self.t, self.xy)


def fly_certificate(cert: "Certificate | Mapping[str, Any]", *, horizon_s: float, attitude: str = "rotorpy",
                    sim_rate_hz: float = 1.0 / DT_S, rate_hz: float | None = None) -> RotorPyFlight:
    """Fly a certificate's reference manoeuvre in RotorPy: at rest at ``xi0_m``, setpoint the origin.

    RotorPy's ``Multirotor`` (aerodynamics off, its attitude loop as the mode
    says) is stepped with the commands of :class:`RotorPyController` in the order
    of ``rotorpy.simulate.simulate`` (the command from the state, then one step
    with it held), without that loop's sensors, which the controller would not
    read (it sees the true state); setpoint RotorPy's ``HoverTraj`` at the
    origin, no wind, rotors at the hover speed at start (as the project's
    reference run).

    Parameters
    ----------
    cert
        A certificate (or its JSON mapping).
    horizon_s
        Flight time [s].
    attitude
        One of :data:`ATTITUDE_MODES`.
    sim_rate_hz
        RotorPy's step rate [Hz] (default the project's own integration rate, ``1/DT_S``).
    rate_hz
        Control rate [Hz]; default the certified one.
    """
    _rotorpy()
    from rotorpy.trajectories.hover_traj import HoverTraj  # the optional test dependency, checked just above
    from rotorpy.vehicles.multirotor import Multirotor

    ctrl = RotorPyController(cert, attitude=attitude, rate_hz=rate_hz)
    v = ctrl.vehicle
    xi0 = np.asarray(ctrl.cert.xi0_m, float)
    start = {"x": between_frames([xi0[0], xi0[1], 0.0]), "v": np.zeros(3), "q": np.array([0.0, 0.0, 0.0, 1.0]),
             "w": np.zeros(3), "wind": np.zeros(3), "rotor_speeds": np.full(4, v.hover_rotor_speed())}
    vehicle = Multirotor(ctrl.quad_params(), initial_state=start, control_abstraction=ctrl.control_abstraction,
                         aero=False)
    trajectory = HoverTraj(x0=np.zeros(3))
    n = int(round(horizon_s * sim_rate_hz))
    dt = 1.0 / sim_rate_hz
    state, positions = start, [start["x"]]
    for k in range(n):  # rotorpy.simulate's order: the command from the state, then one step held
        command = ctrl.update(k * dt, state, trajectory.update(k * dt))
        state = vehicle.step(state, command, dt)
        positions.append(state["x"])
    xy = np.array([between_frames(x)[:2] for x in positions])
    return RotorPyFlight(t=dt * np.arange(n + 1), xy=xy)
