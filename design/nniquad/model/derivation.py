"""The job ``derive``: the vehicle model derived with sympy, as a result object.

Frame: inertial NED (z down), body FRD, thrust ``u1`` along ``-z_B``, ZYX Euler
angles (the frame of the paper's ``f(x, u)``); the z-up form of the
translational dynamics is included.  State order is the paper's,
``x = [x, x', y, y', z, z', phi, phi', theta, theta', psi, psi']``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from nniquad.errors import NniquadError
from nniquad.model import symbolic as S
from nniquad.model.layout import DEFAULT_FRAME, FRAMES

__all__ = ["VARIANTS", "FORMATS", "Equation", "Derivation", "derive"]

#: ``exact``: T_rot = 1/2 w'Jw with body rates w = W(eta) eta'; ``paper``: the paper's T_rot = 1/2 eta'J eta'.
VARIANTS: tuple[str, ...] = ("exact", "paper")
#: Text formats of :meth:`Derivation.render`.
FORMATS: tuple[str, ...] = ("markdown", "latex", "json")


@dataclass(frozen=True)
class Equation:
    """One derived equation: a key, a title and the sympy object."""

    key: str
    title: str
    expr: Any


@dataclass(frozen=True)
class Derivation:
    """The derived model of one variant (see :func:`derive`).

    Attributes
    ----------
    variant
        ``"exact"`` or ``"paper"``.
    equations
        Every equation, in print order.
    """

    variant: str
    equations: tuple[Equation, ...]

    def __getitem__(self, key: str) -> Any:
        for eq in self.equations:
            if eq.key == key:
                return eq.expr
        raise KeyError(key)

    def __repr__(self) -> str:
        keys = ", ".join(eq.key for eq in self.equations)
        return f"Derivation(variant={self.variant!r}, NED/FRD/ZYX, equations: {keys})"

    def to_json(self) -> dict[str, Any]:
        """``{"variant", "frame", "equations": {key: {"title", "expr", "latex"}}}``."""
        import sympy as sp

        return {"variant": self.variant, "frame": "NED inertial, FRD body, ZYX Euler angles",
                "equations": {eq.key: {"title": eq.title, "expr": str(eq.expr), "latex": sp.latex(eq.expr)}
                              for eq in self.equations}}

    def render(self, fmt: str = "markdown") -> str:
        """The model as text.

        Parameters
        ----------
        fmt
            ``"markdown"`` (default), ``"latex"`` or ``"json"``.
        """
        import sympy as sp

        if fmt not in FORMATS:
            raise NniquadError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
        if fmt == "json":
            return json.dumps(self.to_json(), indent=2)
        if fmt == "latex":
            return "\n\n".join(f"% {eq.title}\n\\[ {eq.key} = {sp.latex(eq.expr)} \\]" for eq in self.equations)
        parts = [f"# Quadrotor model ({self.variant} variant)", "", "Frame: NED inertial, FRD body, ZYX Euler angles.",
                 ""]
        for eq in self.equations:
            parts += [f"## {eq.title}", "", "$$", sp.latex(eq.expr), "$$", ""]
        return "\n".join(parts)


def _frame_suffix(frame: str) -> str:
    """Key suffix of a layout's equations: none for '+' (the keys before frames existed), ``_x`` for 'x'."""
    return "" if frame == DEFAULT_FRAME else f"_{frame}"


def derive(variant: str = "exact") -> Derivation:
    """Derive the vehicle model with sympy from the Lagrangian.

    Parameters
    ----------
    variant
        ``"exact"`` (rotational kinetic energy ``1/2 w'Jw`` with body rates
        ``w = W(eta) eta'``: ``M(eta) = W'JW``, Coriolis matrix from the
        Christoffel symbols, rotor gyroscopic torque) or ``"paper"`` (the
        paper's stated ``1/2 eta'J eta'``: ``M = J``, ``C = 0``).

    Returns
    -------
    Derivation
        Rotation ``R``, rate map ``W``, ``M``, ``C``, the translational dynamics
        (NED and z-up), the gyroscopic torque, the rotational dynamics, the mixer
        and rotor-speed sum of each rotor layout (``mixer``, ``Omega_r`` for '+',
        ``mixer_x``, ``Omega_r_x`` for 'x') and the state order.
    """
    if variant not in VARIANTS:
        raise NniquadError(f"variant must be one of {', '.join(VARIANTS)}, got {variant!r}")
    import sympy as sp


    s = S.symbols()
    eqs = [
        ("R", "Rotation body -> inertial, R = Rz(psi) Ry(theta) Rx(phi)", S.rotation_zyx()),
        ("W", "Body rates omega = W(eta) eta_dot", S.euler_rate_matrix()),
        ("M", "Rotational inertia matrix M(eta) in T_rot = 1/2 eta_dot^T M eta_dot",
         S.rotational_inertia_matrix(variant)),
        ("C", "Coriolis matrix C(eta, eta_dot) (Christoffel symbols)", S.coriolis_matrix(variant)),
        ("xi_ddot_ned", "Translational dynamics, NED: xi'' = g e3 - (u1/m) R e3", S.translational_dynamics("ned")),
        ("xi_ddot_zup", "Translational dynamics, z-up: xi'' = -g e3 + (u1/m) R e3", S.translational_dynamics("z-up")),
        ("tau_gyro", "Rotor gyroscopic torque (body frame), -omega x (J_r Omega_r e3)", S.gyroscopic_torque()),
        ("eta_ddot", f"Rotational dynamics eta'' ({variant})", S.rotational_dynamics(variant)),
        *[eq for frame in FRAMES for eq in (
            (f"mixer{_frame_suffix(frame)}", f"Mixer: (u1, tau_phi, tau_theta, tau_psi) = A (w1^2, ..., w4^2), "
                                             f"'{frame}' layout", S.mixer_matrix(frame)),
            (f"Omega_r{_frame_suffix(frame)}", f"Signed rotor-speed sum of the gyroscopic term, '{frame}' layout",
             S.rotor_momentum_sum(frame)))],
        ("state", "State order", sp.Matrix(s.state)),
    ]
    return Derivation(variant, tuple(Equation(k, t, e) for k, t, e in eqs))
