"""A velocity-free horizontal law in discrete time: a reference implementation and its CasADi step.

At the control rate ``f_s = 1/T`` the position ``ξ_k`` (both axes) is sampled
and the law runs once per sample, the exact ZOH equivalent of its realisation
(:meth:`nniquad.laws.base.ControlLaw.zoh`):

.. math:: x_{k+1} = A_d x_k + B_d \\xi_k, \\qquad a_k = C x_k + D \\xi_k + a_{ff,k},

the states of both axes interleaved ``(s1_x, s1_y, s2_x, s2_y, ...)`` as in the
simulator, ``ξ_k`` the position error to the reference and ``a_{ff,k}`` the optional
acceleration feedforward (zero without).  The NNI law, ``C(s) = Γ/(s + Γδ)``: ``z_{k+1} = a z_k + b ξ_k``,
``a = e^{-ΓδT}``, ``b = (1 - a)/δ``, ``a_k = -k_p ξ_k + z_k/m̂`` per axis (its
closed form); the ``sni2`` law's ``(z, z')`` from ``scipy.linalg.expm``,
independently of the closed form the simulator uses.
The command ``a_k`` is held until the next sample.  The output stage is the simulator's
(:mod:`nniquad.control.inner_loops`): the norm limit ``‖a‖ <= g_z tan(T_lim)`` with
``g_z = max(g - a_z, 0.2 g)`` (``a_z`` the altitude loop's vertical command, NED) and the
tilt setpoints ``φ_d, θ_d`` at yaw ``ψ``.  The controller state integrates the measurement
whatever the limit does (as in the simulator), except for a law with anti-windup
(:meth:`nniquad.laws.base.ControlLaw.anti_windup_gains`, the integral laws): its state gets
``W (a_k - sat(a_k))``, ``W = T`` times the anti-windup gains (``q_{k+1} = q_k + T (ξ_k + (a_k - sat(a_k))/k_s)``, ``k_s = k_p (1 - γ)``).

:class:`DiscreteLaw` holds the matrices and steps in numpy (the reference);
:meth:`DiscreteLaw.casadi_step` is the same step as a CasADi function, which
``nniquad export`` turns into C99 source.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from nniquad.control import inner_loops as IL
from nniquad.errors import GainError
from nniquad.laws.base import GainBlock
from nniquad.laws.registry import law_named

__all__ = ["DiscreteLaw", "DiscreteNNI", "STEP_INPUTS", "STEP_OUTPUTS", "step_inputs"]


def step_inputs(n_state: int = 2, unit: str = "N", what: str = "z_k (x, y)") -> tuple[tuple[str, int, str, str], ...]:
    """Inputs of one step: (name, size, unit, meaning); the controller state has ``n_state`` entries.

    Parameters
    ----------
    n_state
        Controller states of both axes.
    unit
        Their units, as the table lists them.
    what
        The state's names, as the table lists them.
    """
    return (
        ("z", n_state, unit, f"controller state {what}, zero at start-up"),
        ("xi", 2, "m", "measured horizontal position xi_k (north, east) relative to the setpoint"),
        ("psi", 1, "rad", "measured yaw angle"),
        ("a_z", 1, "m/s^2", "vertical acceleration command of the altitude loop (NED, 0 at hover)"),
        ("a_ff", 2, "m/s^2", "acceleration feedforward (north, east): the reference's acceleration, added before "
                             "the tilt limit; zero without feedforward"),
    )


#: Inputs of one step of the NNI law: (name, size, unit, meaning).
STEP_INPUTS: tuple[tuple[str, int, str, str], ...] = step_inputs()
#: Outputs of one step.
STEP_OUTPUTS: tuple[tuple[str, int, str, str], ...] = (
    ("z_next", 2, "N", "controller state z_{k+1}"),
    ("a_h", 2, "m/s^2", "horizontal acceleration command (north, east) after the tilt limit, held until the next sample"),
    ("tilt_sp", 2, "rad", "roll and pitch setpoints (phi_d, theta_d) that realise a_h"),
)


@dataclass(frozen=True)
class DiscreteLaw:
    """The discrete-time controller of a velocity-free law, both axes: ``x_{k+1} = A x_k + B ξ_k``,
    ``a_k = C x_k + D ξ_k``.

    Attributes
    ----------
    A, B, C, D : ndarray
        State-space matrices (the law's states, input ξ [m], output a_h [m/s²]); ``A`` is ``(n, n)`` with ``n``
        the law's states of both axes, interleaved.
    T
        Sample period [s].
    g
        Gravity the controller assumes [m/s²].
    tilt_limit_rad
        Tilt limit [rad].
    law
        The law's name (:mod:`nniquad.laws`).
    S : ndarray (n, 2), optional
        Start map: the state at take-over is ``x_0 = S ξ_0`` (:meth:`start`); ``None``: zero (the NNI law).
        ``sni2``: at rest at the DC value, ``S = [C(0) I; 0]``.
    W : ndarray (n, 2), optional
        Anti-windup: the state gets ``W (a_k - sat(a_k))`` (the excess of the tilt limit); ``None``: none.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    T: float
    g: float
    tilt_limit_rad: float
    law: str = "nni"
    S: np.ndarray | None = None
    W: np.ndarray | None = None

    @classmethod
    def from_gains(cls, gains: GainBlock, m_nom: float, g: float, rate_hz: float,
                   tilt_limit_deg: float) -> "DiscreteLaw":
        """Exact ZOH discretisation at ``rate_hz`` (:meth:`nniquad.laws.base.ControlLaw.zoh`: the NNI law's closed
        form, ``scipy.linalg.expm`` for the others).

        Parameters
        ----------
        gains
            The gains of a velocity-free law.
        m_nom
            The controller's nominal mass [kg].
        g
            Gravity the controller assumes [m/s²].
        rate_hz
            Control rate [Hz].
        tilt_limit_deg
            Tilt limit [deg].

        Raises
        ------
        GainError
            Non-positive or non-finite rate, mass, gravity or tilt limit, or a law that reads the velocity.
        """
        for name, v in (("rate", rate_hz), ("nominal mass", m_nom), ("gravity", g)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise GainError(f"{name} must be a finite positive number, got {v!r}")
        if not (isinstance(tilt_limit_deg, (int, float)) and 0 < tilt_limit_deg < 90):
            raise GainError(f"tilt limit must be in (0, 90) deg, got {tilt_limit_deg!r}")
        if not isinstance(gains, GainBlock):
            raise GainError(f"no discrete controller for a {type(gains).__name__}")
        law = gains.law
        if law.measures_velocity:
            raise GainError(f"no discrete velocity-free controller for the {law.name} law: it reads the velocity")
        T = 1.0 / float(rate_hz)
        Ad, Bd = law.zoh(gains, m_nom, T)
        _, _, C, D = law.both_axes(gains, m_nom)
        S = law.start_map(gains, m_nom)
        p = law.parameters(gains, m_nom)
        aw = [law.anti_windup_gains(p, a) for a in (0, 1)]
        W = None
        if any(aw):
            W = np.zeros((Ad.shape[0], 2))
            for a in (0, 1):
                W[a::2, a] = T * np.asarray(aw[a] or np.zeros(law.n_states), float)
        return cls(A=Ad, B=Bd, C=C, D=D, T=T, g=float(g), tilt_limit_rad=math.radians(tilt_limit_deg),
                   law=law.name, S=S if np.any(S) else None, W=W)

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.T

    @property
    def n_state(self) -> int:
        """Number of controller states (both axes)."""
        return self.A.shape[0]

    def start(self, xi0: np.ndarray) -> np.ndarray:
        """The controller state at take-over for the first measured position ``ξ_0`` (zero for the NNI law)."""
        if self.S is None:
            return np.zeros(self.n_state)
        return self.S @ np.asarray(xi0, float)

    def casadi_start(self, name: str = "nniquad_nni_start") -> ca.Function:
        """:meth:`start` as a CasADi function ``xi[2] -> z0[n]`` (``nniquad export`` writes it beside the step)."""
        xi = ca.SX.sym("xi", 2)
        S = np.zeros((self.n_state, 2)) if self.S is None else self.S
        return ca.Function(name, [xi], [ca.mtimes(ca.DM(S), xi)], ["xi"], ["z0"])

    @property
    def state_units(self) -> str:
        """The units of the law's states, as the tables list them (``"N"``, ``"N, N/s"``)."""
        return ", ".join(law_named(self.law).state_units)

    @property
    def state_names(self) -> list[str]:
        """The names of the state entries of both axes, interleaved (``z_x, z_y, zdot_x, zdot_y``)."""
        base = ["z", "zdot", "zddot", "z3"]
        n = self.n_state // 2
        names = [base[i] if i < len(base) else f"z{i}" for i in range(n)]
        if law_named(self.law).integral:  # the integrator q is the last state of each axis
            names = base[: n - 1] + ["q"]
        return [f"{name}_{a}" for name in names for a in "xy"]

    @property
    def step_inputs(self) -> tuple[tuple[str, int, str, str], ...]:
        """Inputs of one step (:func:`step_inputs` with this controller's state size)."""
        what = "z_k (x, y)" if self.n_state == 2 else "(" + ", ".join(self.state_names) + ")_k"
        return step_inputs(self.n_state, self.state_units, what)

    @property
    def step_outputs(self) -> tuple[tuple[str, int, str, str], ...]:
        """Outputs of one step (:data:`STEP_OUTPUTS` with this controller's state size)."""
        z_next = ("z_next", self.n_state, self.state_units, STEP_OUTPUTS[0][3])
        return (z_next,) + STEP_OUTPUTS[1:]

    # ------------------------------------------------------------------ numpy reference
    def step(self, z: np.ndarray, xi: np.ndarray, psi: float = 0.0, a_z: float = 0.0,
             a_ff: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One step in numpy: ``(z_next, a_h, (φ_d, θ_d))`` (see :data:`STEP_OUTPUTS`).

        ``xi`` is the error to the reference, ``ξ_k - ξ_d(t_k)``; the feedforward ``a_ff`` (default zero) joins
        the command before the tilt limit and leaves the state equation alone (:mod:`nniquad.laws.base`,
        "Reference and feedforward").
        """
        z, xi = np.asarray(z, float), np.asarray(xi, float)
        a = self.C @ z + self.D @ xi
        if a_ff is not None:
            a = a + np.asarray(a_ff, float)
        g_z = float(IL.vertical_specific_force(self.g, a_z))
        limit = g_z * math.tan(self.tilt_limit_rad)
        norm = float(np.hypot(a[0], a[1]))
        a_raw, a = a, a * (limit / max(norm, limit))
        # tilt setpoints: thrust direction parallel to (a_x, a_y, -g_z) in the yaw frame
        c, s = math.cos(psi), math.sin(psi)
        bx, by = c * a[0] + s * a[1], -s * a[0] + c * a[1]
        theta_d = math.atan2(-bx, g_z)
        phi_d = math.atan(by * math.cos(theta_d) / g_z)
        z_next = self.A @ z + self.B @ xi
        if self.W is not None:
            z_next = z_next + self.W @ (a_raw - a)
        return z_next, a, np.array([phi_d, theta_d])

    def run(self, xi: np.ndarray, psi: np.ndarray | None = None, a_z: np.ndarray | None = None,
            z0: np.ndarray | None = None, a_ff: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Step through a recorded measurement sequence ``xi`` of shape ``(N, 2)``, from ``z0`` (default:
        :meth:`start` of the first measurement), with the feedforward ``a_ff`` ``(N, 2)`` (default zero).

        Returns
        -------
        dict
            ``z`` (N+1, n), ``a_h`` (N, 2), ``tilt_sp`` (N, 2).
        """
        xi = np.asarray(xi, float)
        n = xi.shape[0]
        psi = np.zeros(n) if psi is None else np.asarray(psi, float)
        a_z = np.zeros(n) if a_z is None else np.asarray(a_z, float)
        a_ff = np.zeros((n, 2)) if a_ff is None else np.asarray(a_ff, float)
        z = np.zeros((n + 1, self.n_state))
        z[0] = (self.start(xi[0]) if n else 0.0) if z0 is None else z0
        ah, sp = np.zeros((n, 2)), np.zeros((n, 2))
        for k in range(n):
            z[k + 1], ah[k], sp[k] = self.step(z[k], xi[k], psi[k], a_z[k], a_ff[k])
        return {"z": z, "a_h": ah, "tilt_sp": sp}

    # ------------------------------------------------------------------ CasADi / C
    def casadi_step(self, name: str = "nniquad_nni_step", *, feedforward: bool = False) -> ca.Function:
        """The step as a CasADi function (inputs :attr:`step_inputs`, outputs :attr:`step_outputs`).

        Built from the same matrices and the simulator's own output stage
        (:func:`nniquad.control.inner_loops.limit_norm`, :func:`~nniquad.control.inner_loops.tilt_setpoints`).
        Without ``feedforward`` the function has the first four inputs (``z, xi, psi, a_z``: the step of the
        first release); with it, also ``a_ff``, added to the command before the tilt limit.

        Parameters
        ----------
        name
            The function's name.
        feedforward
            Take the acceleration feedforward ``a_ff`` as a fifth input.
        """
        inputs = self.step_inputs if feedforward else self.step_inputs[:4]
        syms = [ca.SX.sym(n, k) for n, k, _, _ in inputs]
        z, xi, psi, a_z = syms[:4]
        a = ca.mtimes(ca.DM(self.C), z) + ca.mtimes(ca.DM(self.D), xi)
        if feedforward:
            a = a + syms[4]
        g_z = IL.vertical_specific_force(self.g, a_z)
        a_raw, a = a, IL.limit_norm(a, g_z * math.tan(self.tilt_limit_rad))
        phi_d, theta_d, _ = IL.tilt_setpoints(a, g_z, psi)
        z_next = ca.mtimes(ca.DM(self.A), z) + ca.mtimes(ca.DM(self.B), xi)
        if self.W is not None:  # anti-windup: the excess of this step's own tilt limit
            z_next = z_next + ca.mtimes(ca.DM(self.W), a_raw - a)
        return ca.Function(name, syms, [z_next, a, ca.vertcat(phi_d, theta_d)],
                           [n for n, *_ in inputs], [n for n, *_ in self.step_outputs])

    def to_json(self) -> dict[str, Any]:
        """Matrices with units and the discretisation, for a flight stack."""
        law = law_named(self.law)
        units = {f"state {n}": u for n, u in zip(("z", "z'", "z''"), law.state_units)}
        return {
            "law": self.law,
            "form": "z[k+1] = A z[k] + B xi[k]" + (" + W (a[k] - sat(a[k]))" if self.W is not None else "")
                    + ";  a_h[k] = C z[k] + D xi[k]  (then the tilt limit" + (": sat)" if self.W is not None else ")"),
            "discretisation": law.discretisation_text(),
            "sample_period_s": self.T,
            "rate_hz": self.rate_hz,
            "A": self.A.tolist(), "B": self.B.tolist(), "C": self.C.tolist(), "D": self.D.tolist(),
            **({"W": self.W.tolist()} if self.W is not None else {}),
            "units": {**units, "input xi": "m", "output a_h": "m/s^2", **law.export_matrix_units()},
            "state_names": self.state_names, "input_names": ["xi_x", "xi_y"], "output_names": ["a_x", "a_y"],
            "g_m_s2": self.g,
            "tilt_limit_deg": math.degrees(self.tilt_limit_rad),
            "output_stage": "a_h scaled to norm <= g_z tan(tilt_limit), g_z = max(g - a_z, "
                            f"{IL.G_Z_MIN_FRACTION:g} g); theta_d = atan2(-b_x, g_z), "
                            "phi_d = atan(b_y cos(theta_d)/g_z), b = Rz(-psi) a_h",
        }


#: The name of the first release, when only the NNI law was exported.
DiscreteNNI = DiscreteLaw
