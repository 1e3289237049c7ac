"""Symbolic quadrotor model, derived once with sympy from a Lagrangian.

Every dynamics equation of the project is written here, once; numeric code
(CasADi, numpy) is generated from these expressions by :mod:`nniquad.model.numeric`.

Frames
------
The model is written in the frame the paper's state equation ``f(x, u)``
uses: an inertial **NED** frame (x north, y east, z *down*), a body **FRD**
frame (x forward, y right, z down), thrust ``u1`` along ``-z_B``, and ZYX
(yaw-pitch-roll) Euler angles eta = (phi, theta, psi), so that
``R_{B->E} = Rz(psi) Ry(theta) Rx(phi)``.  Gravity then *adds* ``+g`` to
``z''``: ``xi'' = g e3 - (u1/m) R e3``.

The paper's eq. (translational_dynamics) uses a **z-up** frame instead
(``m xi'' + [0, 0, m g] = F``).  The two are related by a rotation of pi about
the north axis, which is a proper rotation (no handedness change):
``(x, y, z)_up = (x, -y, -z)_NED`` and ``(phi, theta, psi)_up = (phi, -theta, -psi)_NED``
(see :func:`ned_to_zup`).  Every function says which frame it returns.

Rotor layouts
-------------
Two layouts (:func:`rotor_geometry`, the vehicle's ``frame``), all rotors at arm
length ``l`` from the centre, numbered clockwise seen from above:

``'+'``: rotor 1 front (+x_B), 2 right (+y_B), 3 back (-x_B), 4 left (-y_B).
Rotors 1 and 3 spin about +z_B (clockwise seen from above), 2 and 4 about -z_B.

``'x'``: the '+' turned 45° clockwise seen from above: rotor 1 front-right,
2 back-right, 3 back-left, 4 front-left, each ``l/√2`` along both body axes.
Rotors 1 and 3 spin about -z_B (counter-clockwise seen from above), 2 and 4
about +z_B.  Numbering and spins are the Crazyflie's (bitcraze/crazyflie-firmware,
``power_distribution_quadrotor.c``: M1 front-right, M2 back-right, M3 back-left,
M4 front-left; a thrust increase of M1 or M3 gives a clockwise yaw torque seen from
above, so they spin counter-clockwise); PX4's quad X spins its rotors the same way
by position but numbers them 1 front-right, 2 back-left, 3 front-left, 4 back-right.

Each rotor makes thrust ``b w_i^2`` along -z_B and a drag torque ``d w_i^2``
against its spin, so (derived in :func:`mixer_matrix`)::

    '+':  u1        = b (w1^2 + w2^2 + w3^2 + w4^2)
          tau_phi   = l b (w4^2 - w2^2)
          tau_theta = l b (w1^2 - w3^2)
          tau_psi   = d (w2^2 + w4^2 - w1^2 - w3^2)

    'x':  u1        = b (w1^2 + w2^2 + w3^2 + w4^2)
          tau_phi   = (l/√2) b (w3^2 + w4^2 - w1^2 - w2^2)
          tau_theta = (l/√2) b (w1^2 + w4^2 - w2^2 - w3^2)
          tau_psi   = d (w1^2 + w3^2 - w2^2 - w4^2)

and the rotors' net angular momentum is ``Jr * Omega_r * e3_B`` with
``Omega_r = sum_i spin_i w_i`` ('+': ``w1 - w2 + w3 - w4``), which exerts the gyroscopic torque
``-omega x (Jr Omega_r e3)`` on the body.  The paper's inputs ``u2, u3`` are
rotor-thrust differences of the '+' layout (its ``b1 = l/Jx``), so ``tau_phi = l u2``,
``tau_theta = l u3``, ``tau_psi = u4``.  The rigid-body equations in the torques
are the same for both layouts; only the map from rotor speeds to torques differs.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import sympy as sp

from nniquad.model.layout import DEFAULT_FRAME, FRAMES, STATE_ORDER

__all__ = [
    "Symbols",
    "symbols",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_zyx",
    "euler_rate_matrix",
    "skew",
    "time_derivative",
    "euler_lagrange",
    "lagrangian",
    "translational_dynamics",
    "paper_thrust_force",
    "rotational_inertia_matrix",
    "coriolis_matrix",
    "rotational_dynamics",
    "gyroscopic_torque",
    "rotor_reaction_torque",
    "rotor_acceleration_symbols",
    "full_dynamics",
    "paper_full_dynamics",
    "check_frame",
    "rotor_geometry",
    "mixer_matrix",
    "allocation_matrix",
    "rotor_momentum_sum",
    "ned_to_zup",
    "STATE_ORDER",
]



@dataclass(frozen=True)
class Symbols:
    """All sympy symbols of the model (parameters are positive reals)."""

    m: sp.Symbol
    g: sp.Symbol
    Jx: sp.Symbol
    Jy: sp.Symbol
    Jz: sp.Symbol
    Jr: sp.Symbol
    l: sp.Symbol
    b: sp.Symbol
    d: sp.Symbol
    xi: tuple[sp.Symbol, sp.Symbol, sp.Symbol]
    xi_dot: tuple[sp.Symbol, sp.Symbol, sp.Symbol]
    xi_ddot: tuple[sp.Symbol, sp.Symbol, sp.Symbol]
    eta: tuple[sp.Symbol, sp.Symbol, sp.Symbol]
    eta_dot: tuple[sp.Symbol, sp.Symbol, sp.Symbol]
    eta_ddot: tuple[sp.Symbol, sp.Symbol, sp.Symbol]
    u1: sp.Symbol
    tau: tuple[sp.Symbol, sp.Symbol, sp.Symbol]
    Omega_r: sp.Symbol
    rotor: tuple[sp.Symbol, sp.Symbol, sp.Symbol, sp.Symbol]
    frame_index: sp.Symbol

    @property
    def params(self) -> tuple[sp.Symbol, ...]:
        """Vehicle parameters in the order numeric code passes them (:data:`nniquad.model.layout.PARAM_NAMES`).

        ``frame_index`` appears in no expression: the numeric code selects the frame's
        expressions with it (:func:`nniquad.model.numeric.mixer_function`).
        """
        return (self.m, self.g, self.Jx, self.Jy, self.Jz, self.Jr, self.l, self.b, self.d, self.frame_index)

    @property
    def q(self) -> tuple[sp.Symbol, ...]:
        """Generalised coordinates (xi, eta)."""
        return self.xi + self.eta

    @property
    def qd(self) -> tuple[sp.Symbol, ...]:
        return self.xi_dot + self.eta_dot

    @property
    def qdd(self) -> tuple[sp.Symbol, ...]:
        return self.xi_ddot + self.eta_ddot

    @property
    def state(self) -> tuple[sp.Symbol, ...]:
        """The 12-state vector in the paper's order (:data:`STATE_ORDER`)."""
        x, y, z = self.xi
        xd, yd, zd = self.xi_dot
        ph, th, ps = self.eta
        phd, thd, psd = self.eta_dot
        return (x, xd, y, yd, z, zd, ph, phd, th, thd, ps, psd)

    @property
    def inputs(self) -> tuple[sp.Symbol, ...]:
        """(u1, tau_phi, tau_theta, tau_psi, Omega_r)."""
        return (self.u1,) + self.tau + (self.Omega_r,)


@lru_cache(maxsize=1)
def symbols() -> Symbols:
    """The model's symbols (cached, so every function shares the same objects)."""
    pos = dict(positive=True, real=True)
    m, g, Jx, Jy, Jz, Jr, l, b, d = sp.symbols("m g J_x J_y J_z J_r l b d", **pos)
    xi = sp.symbols("x y z", real=True)
    xi_dot = sp.symbols("xdot ydot zdot", real=True)
    xi_ddot = sp.symbols("xddot yddot zddot", real=True)
    eta = sp.symbols("phi theta psi", real=True)
    eta_dot = sp.symbols("phidot thetadot psidot", real=True)
    eta_ddot = sp.symbols("phiddot thetaddot psiddot", real=True)
    u1 = sp.Symbol("u_1", real=True)
    tau = sp.symbols("tau_phi tau_theta tau_psi", real=True)
    Omega_r = sp.Symbol("Omega_r", real=True)
    rotor = sp.symbols("omega_1:5", real=True)
    frame_index = sp.Symbol("k_frame", integer=True, nonnegative=True)
    return Symbols(m, g, Jx, Jy, Jz, Jr, l, b, d, xi, xi_dot, xi_ddot, eta, eta_dot, eta_ddot, u1, tau, Omega_r, rotor,
                   frame_index)


# --------------------------------------------------------------------------- kinematics


def rot_x(a: sp.Expr) -> sp.Matrix:
    """Elementary rotation about x by angle ``a`` (active, right-handed)."""
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


def rot_y(a: sp.Expr) -> sp.Matrix:
    """Elementary rotation about y by angle ``a``."""
    return sp.Matrix([[sp.cos(a), 0, sp.sin(a)], [0, 1, 0], [-sp.sin(a), 0, sp.cos(a)]])


def rot_z(a: sp.Expr) -> sp.Matrix:
    """Elementary rotation about z by angle ``a``."""
    return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])


def rotation_zyx(phi: sp.Expr | None = None, theta: sp.Expr | None = None, psi: sp.Expr | None = None) -> sp.Matrix:
    """Body-to-inertial rotation ``R = Rz(psi) Ry(theta) Rx(phi)`` (ZYX, yaw-pitch-roll).

    Built from the elementary rotations, not typed entry by entry, so that the
    paper's eq. (rotation_matrix) can be compared with it independently.
    """
    s = symbols()
    phi = s.eta[0] if phi is None else phi
    theta = s.eta[1] if theta is None else theta
    psi = s.eta[2] if psi is None else psi
    return rot_z(psi) * rot_y(theta) * rot_x(phi)


def skew(v: Sequence[sp.Expr]) -> sp.Matrix:
    """Cross-product matrix: ``skew(a) * b == a x b``."""
    return sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


@lru_cache(maxsize=None)
def euler_rate_matrix() -> sp.Matrix:
    """``W(eta)`` with body rates ``omega = W(eta) eta_dot``, derived from R.

    Derivation: the body angular velocity satisfies ``skew(omega) = R^T R_dot``;
    differentiating R by the chain rule and reading off the skew entries gives W
    with no hand-typed entries.
    """
    s = symbols()
    R = rotation_zyx()
    R_dot = sum((R.diff(e) * ed for e, ed in zip(s.eta, s.eta_dot)), sp.zeros(3, 3))
    # Only the three independent entries of the skew matrix are needed.
    rows = {(2, 1), (0, 2), (1, 0)}
    entry = {ij: (R[:, ij[0]].T * R_dot[:, ij[1]])[0] for ij in rows}
    omega = sp.Matrix([entry[(2, 1)], entry[(0, 2)], entry[(1, 0)]])
    # sin² = 1 - cos² (an identity) applied to the expanded entries gives trigsimp's result in a
    # fifth of its time; the derivation runs in every process that builds the simulator
    sq = {sp.sin(a) ** 2: 1 - sp.cos(a) ** 2 for a in s.eta}

    def reduce(e: sp.Expr) -> sp.Expr:
        e = sp.expand(e)
        for _ in range(3):
            e = sp.expand(e.subs(sq))
        return e

    return omega.jacobian(sp.Matrix(s.eta_dot)).applyfunc(reduce)


def ned_to_zup(expr_or_matrix: sp.Expr | sp.Matrix) -> sp.Expr | sp.Matrix:
    """Rewrite an expression from NED/FRD variables to z-up/FLU variables.

    The z-up frame is the NED frame rotated by pi about north:
    ``(x, y, z)_up = (x, -y, -z)_NED``, ``(phi, theta, psi)_up = (phi, -theta, -psi)_NED``,
    and likewise for rates and accelerations.  Substitutes the NED symbols by the
    z-up ones (same symbols, reinterpreted), i.e. returns the expression in
    terms of z-up quantities.  Vector-valued results must still be mapped by
    :func:`zup_vector` to express their components in the z-up frame.
    """
    s = symbols()
    sub = {}
    flip = {1: -1, 2: -1}
    for group in (s.xi, s.xi_dot, s.xi_ddot):
        for i, sym in enumerate(group):
            if i in flip:
                sub[sym] = -sym
    for group in (s.eta, s.eta_dot, s.eta_ddot):
        for i, sym in enumerate(group):
            if i in flip:
                sub[sym] = -sym
    return expr_or_matrix.xreplace(sub) if hasattr(expr_or_matrix, "xreplace") else expr_or_matrix


def zup_vector(v: sp.Matrix) -> sp.Matrix:
    """Components of an inertial vector in the z-up frame given its NED components."""
    return sp.diag(1, -1, -1) * v


# --------------------------------------------------------------------------- Lagrangian mechanics


def time_derivative(expr: sp.Expr | sp.Matrix, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol],
                    qdd: Sequence[sp.Symbol]) -> sp.Expr | sp.Matrix:
    """Total time derivative of ``expr(q, qd)`` by the chain rule."""
    return sum((sp.diff(expr, a) * ad for a, ad in zip(q, qd)), sp.S.Zero) + sum(
        (sp.diff(expr, a) * ad for a, ad in zip(qd, qdd)), sp.S.Zero
    )


def euler_lagrange(L: sp.Expr, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol], qdd: Sequence[sp.Symbol]) -> sp.Matrix:
    """Left-hand sides ``d/dt dL/dqd - dL/dq`` of the Euler-Lagrange equations."""
    return sp.Matrix([time_derivative(sp.diff(L, a_d), q, qd, qdd) - sp.diff(L, a) for a, a_d in zip(q, qd)])


@lru_cache(maxsize=None)
def rotational_inertia_matrix(variant: str = "exact") -> sp.Matrix:
    """``M(eta)`` in ``T_rot = 1/2 eta_dot^T M(eta) eta_dot``.

    ``variant="exact"``: ``M = W^T J W`` from ``T_rot = 1/2 omega^T J omega``.
    ``variant="paper"``: ``M = J``, the paper's eq. (T_rot).
    """
    s = symbols()
    J = sp.diag(s.Jx, s.Jy, s.Jz)
    if variant == "paper":
        return J
    if variant != "exact":
        raise ValueError(f"variant must be 'exact' or 'paper', got {variant!r}")
    W = euler_rate_matrix()
    return (W.T * J * W).applyfunc(sp.expand)


def lagrangian(variant: str = "exact", frame: str = "ned") -> sp.Expr:
    """``L = T_trans + T_rot - P`` with ``P = m g (height)``.

    In NED the height is ``-z``; in z-up it is ``z``.
    """
    s = symbols()
    xd = sp.Matrix(s.xi_dot)
    ed = sp.Matrix(s.eta_dot)
    T_trans = sp.Rational(1, 2) * s.m * (xd.T * xd)[0]
    T_rot = sp.Rational(1, 2) * (ed.T * rotational_inertia_matrix(variant) * ed)[0]
    height = -s.xi[2] if frame == "ned" else s.xi[2]
    if frame not in ("ned", "z-up"):
        raise ValueError(f"frame must be 'ned' or 'z-up', got {frame!r}")
    return T_trans + T_rot - s.m * s.g * height


def thrust_force(frame: str = "ned") -> sp.Matrix:
    """Inertial components of the rotor thrust: ``u1`` along the body's lift axis.

    NED/FRD: lift is ``-z_B``, so ``F = -u1 R e3``.  z-up/FLU: ``F = u1 R e3``.
    """
    s = symbols()
    e3 = sp.Matrix([0, 0, 1])
    R = rotation_zyx()
    if frame == "ned":
        return -s.u1 * R * e3
    if frame == "z-up":
        return s.u1 * R * e3
    raise ValueError(f"frame must be 'ned' or 'z-up', got {frame!r}")


def paper_thrust_force() -> sp.Matrix:
    """The paper's eq. (thrust_force), as printed: ``u1 [-s_theta, c_theta s_phi, c_theta c_phi]``."""
    s = symbols()
    ph, th, _ = s.eta
    return s.u1 * sp.Matrix([-sp.sin(th), sp.cos(th) * sp.sin(ph), sp.cos(th) * sp.cos(ph)])


@lru_cache(maxsize=None)
def translational_dynamics(frame: str = "ned") -> sp.Matrix:
    """Accelerations ``xi''`` from the Euler-Lagrange equations of :func:`lagrangian`.

    Solves ``m xi'' + dP/dxi = F_xi`` with the thrust of :func:`thrust_force`.
    NED: ``xi'' = g e3 - (u1/m) R e3``.  z-up: ``xi'' = -g e3 + (u1/m) R e3``.
    """
    s = symbols()
    L = lagrangian("paper", frame)
    lhs = euler_lagrange(L, s.xi, s.xi_dot, s.xi_ddot)
    sol = sp.solve(list(lhs - thrust_force(frame)), s.xi_ddot, dict=True)[0]
    return sp.Matrix([sp.factor_terms(sol[a]) for a in s.xi_ddot])


@lru_cache(maxsize=None)
def coriolis_matrix(variant: str = "exact") -> sp.Matrix:
    """Coriolis/centrifugal matrix ``C(eta, eta_dot)`` by Christoffel symbols of ``M(eta)``.

    ``C_kj = sum_i 1/2 (dM_kj/deta_i + dM_ki/deta_j - dM_ij/deta_k) eta_dot_i``,
    the choice for which ``M_dot - 2 C`` is skew-symmetric.
    """
    s = symbols()
    M = rotational_inertia_matrix(variant)
    n = 3
    C = sp.zeros(n, n)
    for k in range(n):
        for j in range(n):
            C[k, j] = sum(
                sp.Rational(1, 2)
                * (sp.diff(M[k, j], s.eta[i]) + sp.diff(M[k, i], s.eta[j]) - sp.diff(M[i, j], s.eta[k]))
                * s.eta_dot[i]
                for i in range(n)
            )
    return C.applyfunc(sp.expand)


def gyroscopic_torque() -> sp.Matrix:
    """Body-frame torque ``-omega x (Jr Omega_r e3_B)`` of the spinning rotors, with ``omega = W eta_dot``."""
    s = symbols()
    omega = euler_rate_matrix() * sp.Matrix(s.eta_dot)
    return -skew(omega) * sp.Matrix([0, 0, s.Jr * s.Omega_r])


@lru_cache(maxsize=None)
def rotational_dynamics(variant: str = "exact") -> sp.Matrix:
    """Angular accelerations ``eta''`` from the Euler-Lagrange equations.

    The generalised forces conjugate to eta are ``W^T tau_B`` (virtual work
    ``tau_B . omega = tau_B . W eta_dot``), with the body torque
    ``tau_B = tau + gyroscopic torque``.  ``variant="exact"`` uses
    ``T_rot = 1/2 omega^T J omega``; ``variant="paper"`` uses the paper's
    ``T_rot = 1/2 eta_dot^T J eta_dot`` and its generalised forces ``tau``
    (M = J is constant, so C = 0 and ``J eta'' = tau``).

    Returns ``M^{-1} (W^T tau_B - C eta_dot)``, using ``M^{-1} = W^{-1} J^{-1} W^{-T}``
    for the exact variant (exact, as ``M = W^T J W``).
    """
    s = symbols()
    W = euler_rate_matrix()
    tau_B = sp.Matrix(s.tau) + gyroscopic_torque()
    ed = sp.Matrix(s.eta_dot)
    C = coriolis_matrix(variant)
    if variant == "paper":
        # The paper's generalised forces are F = [F_xi, tau] and its T_rot has a
        # constant M = J, so its Lagrangian yields J eta'' = tau: no Coriolis
        # matrix and no rotor gyroscopic term.
        J = rotational_inertia_matrix("paper")
        return J.inv() * sp.Matrix(s.tau)
    rhs = W.T * tau_B - C * ed
    W_inv = W.inv().applyfunc(sp.trigsimp)
    J_inv = sp.diag(1 / s.Jx, 1 / s.Jy, 1 / s.Jz)
    M_inv = W_inv * J_inv * W_inv.T
    return M_inv * rhs


@lru_cache(maxsize=None)
def full_dynamics(variant: str = "exact", frame: str = "ned") -> sp.Matrix:
    """The 12-state model ``x' = f(x, u)`` in the paper's state order, NED frame.

    Inputs are ``(u1, tau_phi, tau_theta, tau_psi)`` and the rotor speed sum
    ``Omega_r`` for the gyroscopic terms (see :class:`Symbols.inputs`).
    """
    s = symbols()
    acc = translational_dynamics(frame)
    eta_dd = rotational_dynamics(variant)
    x, xd, y, yd, z, zd, ph, phd, th, thd, ps, psd = s.state
    return sp.Matrix([xd, acc[0], yd, acc[1], zd, acc[2], phd, eta_dd[0], thd, eta_dd[1], psd, eta_dd[2]])


def paper_full_dynamics() -> sp.Matrix:
    """The paper's eq. (full_dynamics) exactly as printed (u2, u3 thrust differences, u4 yaw torque).

    Returned in terms of the torques: ``u2 = tau_phi / l``, ``u3 = tau_theta / l``,
    ``u4 = tau_psi``, ``omega(u) = Omega_r``.
    """
    s = symbols()
    x1, x2, x3, x4, x5, x6, x7, x8, x9, x10, x11, x12 = s.state
    m, g, Jx, Jy, Jz, Jr, l = s.m, s.g, s.Jx, s.Jy, s.Jz, s.Jr, s.l
    u1 = s.u1
    u2, u3, u4 = s.tau[0] / l, s.tau[1] / l, s.tau[2]
    w = s.Omega_r
    a1, a2, a3, a4, a5 = (Jy - Jz) / Jx, Jr / Jx, (Jz - Jx) / Jy, Jr / Jy, (Jx - Jy) / Jz
    b1, b2, b3 = l / Jx, l / Jy, 1 / Jz
    sin, cos = sp.sin, sp.cos
    return sp.Matrix([
        x2,
        -u1 / m * (sin(x7) * sin(x11) + cos(x7) * sin(x9) * cos(x11)),
        x4,
        u1 / m * (sin(x7) * cos(x11) - cos(x7) * sin(x9) * sin(x11)),
        x6,
        g - u1 / m * cos(x7) * cos(x9),
        x8,
        x10 * x12 * a1 - x10 * a2 * w + b1 * u2,
        x10,
        x8 * x12 * a3 + x8 * a4 * w + b2 * u3,
        x12,
        x10 * x8 * a5 + b3 * u4,
    ])


# --------------------------------------------------------------------------- rotors


def check_frame(frame: str) -> str:
    """``frame`` if it names a layout of :data:`nniquad.model.layout.FRAMES`, else ``ValueError``."""
    if frame not in FRAMES:
        raise ValueError(f"frame must be one of {', '.join(repr(f) for f in FRAMES)}, got {frame!r}")
    return frame


def rotor_geometry(frame: str = DEFAULT_FRAME) -> tuple[list[sp.Matrix], list[int]]:
    """Rotor positions in the body FRD frame and spin signs (+1: spin about +z_B) of a layout.

    Rotor ``i`` sits at the angle ``a + (i - 1) pi/2`` from the nose, clockwise seen
    from above (from +x_B towards +y_B), with ``a = 0`` for '+' and ``pi/4`` for 'x'
    (module docstring); sympy's exact ``cos(pi/4) = sqrt(2)/2`` gives the 'x' arm
    component ``l/sqrt(2)`` along each body axis.
    """
    s = symbols()
    offset, spins = {"+": (sp.S.Zero, [1, -1, 1, -1]), "x": (sp.pi / 4, [-1, 1, -1, 1])}[check_frame(frame)]
    angles = [offset + k * sp.pi / 2 for k in range(4)]
    positions = [sp.Matrix([s.l * sp.cos(a), s.l * sp.sin(a), 0]) for a in angles]
    return positions, spins


@lru_cache(maxsize=None)
def mixer_matrix(frame: str = DEFAULT_FRAME) -> sp.Matrix:
    """``A`` with ``(u1, tau_phi, tau_theta, tau_psi) = A (w1^2, ..., w4^2)``, derived from the geometry.

    Thrust of rotor i is ``b w_i^2`` along -z_B at position ``r_i``, giving the torque
    ``r_i x (-b w_i^2 e3)``; its drag reaction on the body is ``-spin_i d w_i^2 e3``.
    """
    s = symbols()
    positions, spins = rotor_geometry(frame)
    e3 = sp.Matrix([0, 0, 1])
    cols = []
    for r, spin in zip(positions, spins):
        force = -s.b * e3
        torque = r.cross(force) - spin * s.d * e3
        cols.append(sp.Matrix([s.b, torque[0], torque[1], torque[2]]))
    return sp.Matrix.hstack(*cols)


@lru_cache(maxsize=None)
def allocation_matrix(frame: str = DEFAULT_FRAME) -> sp.Matrix:
    """``B`` with the rotor thrusts ``(b w1^2, ..., b w4^2) = B (u1, tau_phi, tau_theta, tau_psi)``.

    The exact inverse of the thrust mixer ``A / b`` (:func:`mixer_matrix`); the
    allocation of :func:`nniquad.control.inner_loops.allocate` splits its columns.
    """
    s = symbols()
    return (mixer_matrix(frame) / s.b).inv().applyfunc(sp.simplify)


def rotor_momentum_sum(frame: str = DEFAULT_FRAME) -> sp.Expr:
    """``Omega_r`` as a function of the rotor speeds: ``sum_i spin_i w_i``."""
    s = symbols()
    _, spins = rotor_geometry(frame)
    return sum(spin * w for spin, w in zip(spins, s.rotor))


@lru_cache(maxsize=1)
def rotor_acceleration_symbols() -> tuple[sp.Symbol, sp.Symbol, sp.Symbol, sp.Symbol]:
    """Symbols of the rotor accelerations ``d(omega_i)/dt`` [rad/s²] (motor lag)."""
    return sp.symbols("omegadot_1:5", real=True)


@lru_cache(maxsize=None)
def rotor_reaction_torque(frame: str = DEFAULT_FRAME) -> sp.Matrix:
    """Body-frame torque on the airframe from spinning the rotors up or down: ``-Jr dOmega_r/dt e3_B``.

    The rotors' angular momentum relative to the body is ``h = Jr Omega_r e3_B``
    (:func:`rotor_momentum_sum`).  The motors exert ``dh/dt`` (taken in the body
    frame) on the rotors and, by reaction, ``-dh/dt`` on the airframe; the part
    ``-omega x h`` from the body's rotation is :func:`gyroscopic_torque`, the
    remaining part is derived here by the chain rule through the rotor speeds,
    ``-Jr sum_i spin_i omegadot_i e3_B``.  It matters only where the rotor
    speeds are states (motor lag); with instant speed changes it would be an impulse.
    Expressed in the symbols of :func:`rotor_acceleration_symbols`.
    """
    s = symbols()
    h = s.Jr * rotor_momentum_sum(frame) * sp.Matrix([0, 0, 1])
    rotor_dot = rotor_acceleration_symbols()
    h_dot = sum((h.diff(w) * wd for w, wd in zip(s.rotor, rotor_dot)), sp.zeros(3, 1))
    return -h_dot
