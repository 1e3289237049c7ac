"""Numeric functions generated from the symbolic model (CasADi and numpy).

No dynamics equation is typed here: every function is produced by
:func:`sympy.lambdify` (with common-subexpression elimination) from the
expressions of :mod:`nniquad.model.symbolic`, either onto CasADi ``SX`` symbols, giving
a named :class:`casadi.Function`, or onto numpy.

Vehicle parameters are an *input* of every generated function (vector ``p`` in
the order of :attr:`nniquad.model.symbolic.Symbols.params`), so one compiled function
serves every vehicle, including the perturbed vehicles of a Monte Carlo study.
The rotor layout is one of them (``frame_index``): a function that depends on it
holds each layout's expressions, generated from its own geometry, and returns the
one ``p`` selects (:func:`by_frame`), so a '+' and an 'x' vehicle share compiled code
but never a mixer.

sympy is imported only when a function is generated: the CasADi functions are
kept between processes by :mod:`nniquad.codecache`, so a process that finds
them there never imports it.
"""

from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

import casadi as ca
import numpy as np

from nniquad.codecache import cached_casadi_function
from nniquad.model.layout import FRAMES, PARAM_NAMES
from nniquad.model.vehicle import Vehicle

if TYPE_CHECKING:
    import sympy as sp

__all__ = [
    "PARAM_NAMES",
    "param_vector",
    "casadi_function",
    "numpy_function",
    "dynamics_function",
    "dynamics_numpy",
    "by_frame",
    "mixer_function",
    "mixer_numpy",
    "allocation_function",
    "allocation_numpy",
    "rotor_modes",
    "reaction_torque_function",
    "rotation_function",
]


_CASADI_MODULE = {
    "sin": ca.sin, "cos": ca.cos, "tan": ca.tan, "sqrt": ca.sqrt, "exp": ca.exp, "log": ca.log,
    "Abs": ca.fabs, "sign": ca.sign, "atan2": ca.atan2, "asin": ca.asin, "acos": ca.acos, "atan": ca.atan,
    "Max": ca.fmax, "Min": ca.fmin,
}


def param_vector(vehicle: Vehicle) -> np.ndarray:
    """Vehicle parameters as the vector ``p`` the generated functions take."""
    return np.array([getattr(vehicle, name) for name in PARAM_NAMES], dtype=float)


def _flatten(outputs: Mapping[str, sp.Matrix | sp.Expr]) -> list[list[sp.Expr]]:
    import sympy as sp

    return [list(sp.Matrix([e]) if not isinstance(e, sp.MatrixBase) else e) for e in outputs.values()]


def casadi_function(
    name: str,
    inputs: Mapping[str, Sequence[sp.Symbol]],
    outputs: Mapping[str, sp.Matrix | sp.Expr],
) -> ca.Function:
    """Turn sympy expressions into a named :class:`casadi.Function` (SX, with CSE).

    Parameters
    ----------
    name
        Function name.
    inputs
        Input name -> the sympy symbols packed into that (column) input, in order.
    outputs
        Output name -> expression or matrix (matrices keep their shape).
    """
    import sympy as sp

    sx_in = {key: ca.SX.sym(key, len(syms)) for key, syms in inputs.items()}
    flat_syms = [sym for syms in inputs.values() for sym in syms]
    flat_args = [sx_in[key][i] for key, syms in inputs.items() for i in range(len(syms))]
    exprs = _flatten(outputs)
    shapes = [e.shape if isinstance(e, sp.MatrixBase) else (1, 1) for e in outputs.values()]
    fn = sp.lambdify(flat_syms, exprs, modules=[_CASADI_MODULE], cse=True)
    values = fn(*flat_args)
    sx_out = []
    for col, (rows, cols) in zip(values, shapes):
        flat = ca.vertcat(*[ca.SX(v) if not isinstance(v, ca.SX) else v for v in col])
        # sympy flattens row-major, casadi reshapes column-major: reshape transposed, then transpose
        sx_out.append(ca.reshape(flat, cols, rows).T)
    return ca.Function(name, list(sx_in.values()), sx_out, list(sx_in.keys()), list(outputs.keys()))


def numpy_function(
    inputs: Sequence[sp.Symbol],
    output: sp.Matrix | sp.Expr,
) -> Callable[..., np.ndarray]:
    """Turn a sympy expression or matrix into a numpy function of the given symbols (with CSE)."""
    import sympy as sp

    return sp.lambdify(list(inputs), output, modules="numpy", cse=True)


def _dynamics_inputs() -> dict[str, tuple[sp.Symbol, ...]]:

    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none
    s = S.symbols()
    return {"x": s.state, "u": (s.u1,) + s.tau, "Omega_r": (s.Omega_r,), "p": s.params}


@cached_casadi_function
def dynamics_function(variant: str = "exact") -> ca.Function:
    """CasADi function ``f(x[12], u[4], Omega_r, p[9]) -> xdot[12]`` of the 12-state model (NED).

    ``u = (u1 [N], tau_phi, tau_theta, tau_psi [N m])``; ``Omega_r`` [rad/s] is the
    signed rotor-speed sum of the gyroscopic term; ``variant`` as in
    :func:`nniquad.model.symbolic.full_dynamics` (``"exact"`` or ``"paper"``), or
    ``"paper-printed"`` for the paper's eq. (full_dynamics) as printed.
    """
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none

    f = S.paper_full_dynamics() if variant == "paper-printed" else S.full_dynamics(variant)
    return casadi_function(f"quadrotor_{variant.replace('-', '_')}", _dynamics_inputs(), {"xdot": f})


@lru_cache(maxsize=None)
def dynamics_numpy(variant: str = "exact") -> Callable[..., np.ndarray]:
    """Numpy version of :func:`dynamics_function`: ``f(x, u, Omega_r, p) -> xdot`` (1-D arrays)."""
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none

    f = S.paper_full_dynamics() if variant == "paper-printed" else S.full_dynamics(variant)
    s = S.symbols()
    raw = numpy_function(list(s.state) + [s.u1, *s.tau, s.Omega_r, *s.params], f)

    def evaluate(x: np.ndarray, u: np.ndarray, omega_r: float, p: np.ndarray) -> np.ndarray:
        return np.asarray(raw(*np.asarray(x, float), *np.asarray(u, float), float(omega_r), *np.asarray(p, float)),
                          dtype=float).reshape(-1)

    return evaluate


def by_frame(p: ca.SX, cases: Sequence[ca.SX]) -> ca.SX:
    """The entry of ``cases`` (one per layout of :data:`FRAMES`, in order) that ``p``'s ``frame_index`` selects.

    An index that names no layout selects the first one; a :class:`Vehicle` cannot hold one.
    """
    index = p[PARAM_NAMES.index("frame_index")]
    out = cases[0]
    for k, case in enumerate(cases[1:], start=1):
        out = ca.if_else(ca.fabs(index - k) < 0.5, case, out)
    return out


def _per_frame(name: str, inputs: Mapping[str, Sequence[sp.Symbol]],
               outputs: Callable[[str], Mapping[str, sp.Matrix | sp.Expr]]) -> ca.Function:
    """One CasADi function of ``inputs`` (``p`` among them) whose outputs are ``outputs(frame)`` of ``p``'s frame."""
    sx_in = {key: ca.SX.sym(key, len(syms)) for key, syms in inputs.items()}
    per_frame = [casadi_function(f"{name}_{k}", inputs, outputs(frame))(**sx_in) for k, frame in enumerate(FRAMES)]
    names = list(outputs(FRAMES[0]))
    sx_out = [by_frame(sx_in["p"], [values[key] for values in per_frame]) for key in names]
    return ca.Function(name, list(sx_in.values()), sx_out, list(sx_in), names)


@cached_casadi_function
def mixer_function() -> ca.Function:
    """CasADi ``mixer(w[4], p) -> (u[4], Omega_r)``: rotor speeds [rad/s] to thrust/torques, for ``p``'s frame."""
    import sympy as sp
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none

    s = S.symbols()
    w2 = sp.Matrix([w**2 for w in s.rotor])
    return _per_frame("mixer", {"w": s.rotor, "p": s.params},
                      lambda frame: {"u": S.mixer_matrix(frame) * w2, "Omega_r": S.rotor_momentum_sum(frame)})


@cached_casadi_function
def allocation_function() -> ca.Function:
    """CasADi ``allocation(p) -> B[4x4]``: rotor thrusts ``b w²`` [N] per ``(u1, τ)`` for ``p``'s frame.

    :func:`nniquad.model.symbolic.allocation_matrix`, the exact inverse of the thrust mixer.
    """
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none

    s = S.symbols()
    return _per_frame("allocation", {"p": s.params}, lambda frame: {"B": S.allocation_matrix(frame)})


@cached_casadi_function
def reaction_torque_function() -> ca.Function:
    """CasADi ``reaction(w_dot[4], p) -> tau[3]``: body torque [N m] of the rotor spin-up, for ``p``'s frame.

    :func:`nniquad.model.symbolic.rotor_reaction_torque`, ``-Jr dOmega_r/dt e3_B``.
    """
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none

    s = S.symbols()
    return _per_frame("rotor_reaction", {"w_dot": S.rotor_acceleration_symbols(), "p": s.params},
                      lambda frame: {"tau": S.rotor_reaction_torque(frame)})


@lru_cache(maxsize=None)
def _matrix_numpy(which: str, frame: str) -> Callable[..., np.ndarray]:
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none

    s = S.symbols()
    return numpy_function(list(s.params), getattr(S, which)(frame))


def mixer_numpy(vehicle: Vehicle) -> np.ndarray:
    """The 4x4 mixer matrix ``A`` (``u = A w^2``) of a vehicle and its frame, as numpy."""
    return np.asarray(_matrix_numpy("mixer_matrix", vehicle.frame)(*param_vector(vehicle)), dtype=float)


def allocation_numpy(vehicle: Vehicle) -> np.ndarray:
    """The 4x4 allocation matrix ``B`` (rotor thrusts ``= B (u1, τ)``) of a vehicle and its frame, as numpy."""
    return np.asarray(_matrix_numpy("allocation_matrix", vehicle.frame)(*param_vector(vehicle)), dtype=float)


@lru_cache(maxsize=None)
def rotor_modes(frame: str) -> np.ndarray:
    """The rows of a layout's mixer, each of unit length: collective, roll, pitch and yaw rotor modes.

    Orthonormal for both layouts (tested); at hover the rotor speeds in these
    coordinates feed one subsystem each (:func:`nniquad.analysis.cascade.family.mode_transform`).
    They do not depend on the parameters' values, only on the geometry.
    """
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none

    A = np.asarray(_matrix_numpy("mixer_matrix", frame)(*np.ones(len(PARAM_NAMES))), dtype=float)
    S.check_frame(frame)
    return A / np.linalg.norm(A, axis=1, keepdims=True)


@cached_casadi_function
def rotation_function() -> ca.Function:
    """CasADi ``rotation(eta[3]) -> (R[3x3], W[3x3])``."""
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none

    s = S.symbols()
    return casadi_function(
        "rotation",
        {"eta": s.eta},
        {"R": S.rotation_zyx(), "W": S.euler_rate_matrix()},
    )
