"""``nniquad derive``: print the symbolic vehicle model."""

from __future__ import annotations

import argparse
import json
import sys

HELP = "print the symbolic vehicle model (LaTeX, Markdown or JSON)"
DESCRIPTION = """Print the vehicle model derived with sympy from the Lagrangian.

Frame: inertial NED (z down), body FRD, thrust u1 along -z_B, ZYX Euler angles
(the frame of the paper's f(x, u)); the z-up form of the translational dynamics
is printed too.  State order is the paper's:
x = [x, x', y, y', z, z', phi, phi', theta, theta', psi, psi'].

Variants:
  exact   T_rot = 1/2 w^T J w with body rates w = W(eta) eta'  (M(eta) = W^T J W,
          Coriolis matrix from Christoffel symbols, rotor gyroscopic torque)
  paper   the paper's stated T_rot = 1/2 eta'^T J eta' (M = J, C = 0)

Formats: markdown (default), latex, json (sympy srepr-free plain strings)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--variant", choices=("exact", "paper"), default="exact", help="rotational kinetic energy used (default: exact)")
    parser.add_argument("--format", choices=("markdown", "latex", "json"), default="markdown", help="output format (default: markdown)")
    parser.add_argument("--out", metavar="FILE", default=None, help="write to FILE instead of standard output")


def model_equations(variant: str) -> list[tuple[str, str, object]]:
    """(key, title, sympy object) of every equation printed by ``derive``."""
    import sympy as sp

    from nniquad.model import symbolic as S

    s = S.symbols()
    eta_dd = S.rotational_dynamics(variant)
    return [
        ("R", "Rotation body -> inertial, R = Rz(psi) Ry(theta) Rx(phi)", S.rotation_zyx()),
        ("W", "Body rates omega = W(eta) eta_dot", S.euler_rate_matrix()),
        ("M", "Rotational inertia matrix M(eta) in T_rot = 1/2 eta_dot^T M eta_dot", S.rotational_inertia_matrix(variant)),
        ("C", "Coriolis matrix C(eta, eta_dot) (Christoffel symbols)", S.coriolis_matrix(variant)),
        ("xi_ddot_ned", "Translational dynamics, NED: xi'' = g e3 - (u1/m) R e3", S.translational_dynamics("ned")),
        ("xi_ddot_zup", "Translational dynamics, z-up: xi'' = -g e3 + (u1/m) R e3", S.translational_dynamics("z-up")),
        ("tau_gyro", "Rotor gyroscopic torque (body frame), -omega x (J_r Omega_r e3)", S.gyroscopic_torque()),
        ("eta_ddot", f"Rotational dynamics eta'' ({variant})", eta_dd),
        ("mixer", "Mixer: (u1, tau_phi, tau_theta, tau_psi) = A (w1^2, ..., w4^2), '+' layout", S.mixer_matrix()),
        ("Omega_r", "Signed rotor-speed sum of the gyroscopic term", S.rotor_momentum_sum()),
        ("state", "State order", sp.Matrix(s.state)),
    ]


def render(variant: str, fmt: str) -> str:
    """The model as text in the requested format."""
    import sympy as sp

    eqs = model_equations(variant)
    if fmt == "json":
        return json.dumps(
            {"variant": variant, "frame": "NED inertial, FRD body, ZYX Euler angles",
             "equations": {key: {"title": title, "expr": str(obj), "latex": sp.latex(obj)} for key, title, obj in eqs}},
            indent=2,
        )
    if fmt == "latex":
        return "\n\n".join(f"% {title}\n\\[ {key} = {sp.latex(obj)} \\]" for key, title, obj in eqs)
    parts = [f"# Quadrotor model ({variant} variant)", "", "Frame: NED inertial, FRD body, ZYX Euler angles.", ""]
    for key, title, obj in eqs:
        parts += [f"## {title}", "", "$$", f"{sp.latex(obj)}", "$$", ""]
    return "\n".join(parts)


def run(args: argparse.Namespace) -> int:
    print("deriving the model with sympy ...", file=sys.stderr, flush=True)
    text = render(args.variant, args.format)
    if args.out:
        from nniquad.io import atomic_write_text

        atomic_write_text(args.out, text + "\n")
        print(f"wrote {args.out}", file=sys.stderr)
    else:
        print(text)
    return 0
