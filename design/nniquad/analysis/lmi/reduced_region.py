"""Region of attraction of the tilt-limited loop, and the certified reach computed from it.

:func:`region_of_attraction` solves the generalised-sector-condition LMI of one
axis; :func:`certified_region` chooses the saturation model for a loop (the
norm limit when both axes share ``kp``, the inscribed per-axis limit otherwise)
and :func:`certified_reach` turns it into the one number every caller uses: the
largest displacement from rest certified to converge.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from nniquad.analysis.lmi import checks as K
from nniquad.analysis.lmi.solver import LMIResult, as_data, cpsym, result_fail, solve, solved
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.config import TILT_LIMIT_DEG, XI0_M
from nniquad.errors import GainError, SolverError

__all__ = ["ROA_SCALINGS", "axis_acceleration_limit", "roa_scalings", "region_of_attraction", "certified_region",
           "certified_reach", "reach_of", "start_certified"]


def axis_acceleration_limit(g: float, tilt_limit_deg: float = TILT_LIMIT_DEG, split: str = "norm") -> float:
    """Horizontal acceleration limit ``u0`` used in the region-of-attraction LMI (m/s^2).

    At tilt θ with the vertical thrust balancing gravity the horizontal
    acceleration is ``g tan θ``; the reduced model limits the *norm* of the
    2-D command, ``‖a_h‖ <= g tan θ``.

    * ``split='norm'`` (default) returns ``g tan θ``.  When both axes have the
      same gains the 2-D loop commutes with rotations of the horizontal plane,
      so a rotation-invariant ellipsoid ``P1 ⊗ I2`` loses nothing; the norm
      dead-zone ``ψ = a (1 - u0/‖a‖)_+`` satisfies ``ψ'(ψ - G x) <= 0`` whenever
      ``‖(K - G) x‖ <= u0`` (because ``a'(a - w) <= ‖a‖ ‖a - w‖``), and with a
      scalar multiplier every LMI reduces to the single-axis LMI with limit
      ``u0``.  The certified set is ``{x_x' P1 x_x + x_y' P1 x_y <= 1}``; from rest
      it contains every displacement of norm up to ``max_displacement_m``.
    * ``split='inscribed'`` returns ``g tan θ / sqrt(2)``: clipping each axis
      there keeps the vector inside the norm limit; used when the axes differ.
    * ``split='box'`` returns ``g tan θ`` per axis (a different, box-limited loop).

    Parameters
    ----------
    g
        Gravitational acceleration [m/s^2].
    tilt_limit_deg
        Tilt limit [deg], in (0, 90).
    split
        ``'norm'``, ``'inscribed'`` or ``'box'`` (see above).
    """
    if not (0.0 < tilt_limit_deg < 90.0):
        raise GainError(f"tilt limit must be in (0, 90) degrees, got {tilt_limit_deg}")
    a = float(g) * math.tan(math.radians(tilt_limit_deg))
    if split == "inscribed":
        return a / math.sqrt(2.0)
    if split in ("box", "norm"):
        return a
    raise GainError(f"split must be 'norm', 'inscribed' or 'box', got {split!r}")


def _cp():
    import cvxpy as cp

    return cp


#: The scalings :func:`region_of_attraction` tries by default, in this order (see :func:`roa_scalings`).
ROA_SCALINGS: tuple[str, ...] = ("balanced", "physical", "none")


def roa_scalings(A_cl: np.ndarray, B: np.ndarray, K: np.ndarray,
                 u0: float) -> dict[str, tuple[np.ndarray, float, float]]:
    """Candidate scalings ``(d, omega, psi)`` of the region-of-attraction LMI of one axis.

    The LMI is solved for ``x~ = D^{-1} x`` (``D = diag(d)``), in the time
    ``t~ = omega t`` and with the dead-zone output measured in units of ``psi``.
    Every scaling is exact (a congruence of each LMI), so it changes no answer in
    exact arithmetic; it only decides whether Clarabel's tolerances (about 1e-8,
    absolute) are small against the problem's numbers.  Unscaled, a loop at the
    edge of the tuner's box (``kp = 2000``: the linear zone of the saturation is
    ``u0/kp = 3 mm``, the controller state is ``m kp = 1000`` times the position,
    the loop runs at ``sqrt(kp) = 45 rad/s``) has entries from 1e-3 to 1e7 and the
    solver's "optimal" answer fails the numpy re-check by 3e-5 (docs/notes/tuning.md).

    * ``'balanced'``: ``d`` from :func:`scipy.linalg.matrix_balance` of ``A_cl``
      (rows and columns of equal norm), normalised so that ``d[0] = u0/|K[0]|``,
      the displacement at which the position term alone saturates the command;
      ``omega = sqrt(|K[0] B[1]|)``, the natural frequency of the inner loop
      (``sqrt(kp)``); ``psi = u0``.  The reach is then of order 1 in these units.
    * ``'physical'``: the same position unit and time scale, the velocity in units
      of ``omega d[0]`` and the controller state in units of ``|K[0]/K[2]| d[0]``
      (``m kp`` times the position: the state whose term ``z/m`` balances ``kp xi``);
      each further controller state (the ``sni2`` law's ``z'``) in the unit of the one before it times the
      controller's natural frequency ``sqrt(|A_cl[3, 2]|)``.
    * ``'none'``: the original variables (``d = 1``, ``omega = 1``, ``psi = 1``).

    Parameters
    ----------
    A_cl, B, K
        The closed loop, the saturation input and the acceleration command row
        (:meth:`nniquad.analysis.reduced_loop.ReducedLoop.saturation_split`).
    u0
        Acceleration limit [m/s^2].

    Returns
    -------
    dict
        ``{name: (d, omega, psi)}`` for every name of :data:`ROA_SCALINGS`.
    """
    from scipy.linalg import matrix_balance

    k_pos = abs(float(K[0, 0]))
    if k_pos == 0.0 or not math.isfinite(k_pos):
        ones = np.ones(A_cl.shape[0])
        return {"balanced": (ones, 1.0, 1.0), "physical": (ones, 1.0, 1.0), "none": (ones, 1.0, 1.0)}
    length = u0 / k_pos
    omega = math.sqrt(k_pos * abs(float(B[1, 0])))
    _, (s, _) = matrix_balance(A_cl, permute=False, separate=True)
    balanced = np.asarray(s, dtype=float) / float(s[0]) * length
    # [xi, xi', z, z', ...]: z balances kp xi; each further controller state is the one before it at the
    # controller's own frequency (the sni2 law's z', from its A_cl[3, 2] = -omega^2)
    k_z = abs(float(K[0, 2]))
    z_unit = k_pos / k_z if k_z > 0 else 1.0
    w_c = math.sqrt(abs(float(A_cl[3, 2]))) if A_cl.shape[0] > 3 and abs(float(A_cl[3, 2])) > 0 else omega
    physical = length * np.array([1.0, omega] + [z_unit * w_c**i for i in range(A_cl.shape[0] - 2)])
    return {"balanced": (balanced, omega, u0), "physical": (physical, omega, u0),
            "none": (np.ones(A_cl.shape[0]), 1.0, 1.0)}


def _roa_scaled(A_cl: np.ndarray, B: np.ndarray, Kc: np.ndarray, u0: float, d: np.ndarray, omega: float,
                psi: float, r_cap: float, eta: float, name: str, start: np.ndarray):
    """Solve the region-of-attraction LMI in one scaling; the answer in the original variables, or None.

    Returns ``(status, answer)`` with ``answer = (W, Z, S, r)`` (``W = P^{-1}``,
    ``Z = G W``, ``S = T^{-1}``, the reach ``r`` in m) or ``None`` when the solver
    gave no solution.  The solver's point is first *polished* in the scaled
    variables: the decrease LMI is homogeneous in ``(W, Z, S)``, so scaling all
    three by the factor that makes the inclusion LMI exactly active (less 1e-9)
    keeps the decrease and removes the solver's inclusion residual; the reach is
    then the start level that the polished ``P`` really certifies.  The numpy
    re-check of the caller decides whether the answer certifies anything.
    """
    cp = _cp()
    n = A_cl.shape[0]
    D, Di = np.diag(d), np.diag(1.0 / d)
    At = Di @ A_cl @ D / omega
    Bt = psi * (Di @ B) / omega
    Kt = (Kc @ D) / psi
    ut = u0 / psi
    # the start state per metre, in the scaled state and in units of d[0] (its position entry is 1)
    e1 = (float(d[0]) * np.asarray(start, float) / d).reshape(n, 1)
    W = cp.Variable((n, n), symmetric=True, name="W")
    Z = cp.Variable((1, n), name="Z")
    S = cp.Variable((1, 1), name="S")
    rho = cp.Variable(name="rho")  # the reach in units of d[0]: x~(0) = rho e1 (e1: the scaled start direction)
    dec = cp.bmat([[At @ W + W @ At.T, -Bt @ S + Z.T], [Z - S @ Bt.T, -2 * S]])
    inc = cp.bmat([[W, (Kt @ W - Z).T], [Kt @ W - Z, np.array([[ut**2]])]])
    start = cp.bmat([[W, rho * e1], [rho * e1.T, np.ones((1, 1))]])
    rho_cap = r_cap / float(d[0])
    cons = [cpsym(dec) << -eta * np.eye(n + 1), cpsym(inc) >> 0, cpsym(start) >> 0, S >= eta, rho >= 0,
            rho <= rho_cap]
    status = solve(cp.Problem(cp.Maximize(rho), cons), name)
    if not solved(status) or W.value is None:
        return status, None
    Wt, Zt, St, rho_v = K.sym(np.asarray(W.value)), np.asarray(Z.value), np.asarray(S.value), float(rho.value)
    if K.eigmin(Wt) > 0:
        Gt = Zt @ np.linalg.inv(Wt)
        q = float(((Kt - Gt) @ Wt @ (Kt - Gt).T)[0, 0])
        if q > 0 and St[0, 0] > 0:
            c = (1.0 - 1e-9) * ut**2 / q
            Wt, Zt, St = c * Wt, c * Zt, c * St
            rho_v = min((1.0 - 1e-9) / math.sqrt(float((e1.T @ np.linalg.solve(Wt, e1))[0, 0])), rho_cap)
    # back to the original variables: W = D W~ D, G = psi G~ D^{-1} (so Z = G W = psi Z~ D),
    # T = omega T~ / psi^2 (so S = psi^2 S~ / omega); the decrease matrix is a congruence of the scaled one
    return status, (K.sym(D @ Wt @ D), psi * (Zt @ D), (psi**2 / omega) * St, rho_v * float(d[0]))


def region_of_attraction(loop: ReducedLoop, u0: float, *, axis: str = "x", name: str = "region_of_attraction",
                         r_cap: float = 1e4, scaling: str | Sequence[str] = ROA_SCALINGS,
                         start: Sequence[float] | None = None) -> LMIResult:
    """Certified ellipsoidal region of attraction of one axis under acceleration saturation.

    Model (one axis): ``x = [xi, xi_dot, z]``, ``x' = A0 x + B sat_u0(K x)`` with
    ``K x = -kp xi + z/m`` the acceleration command (:meth:`ReducedLoop.saturation_split`).
    With the dead zone ``psi(v) = v - sat(v)``, ``x' = A_cl x - B psi(Kx)``.  The
    generalised sector condition (Tarbouriech, Garcia, Gomes da Silva & Queinnec,
    *Stability and Stabilization of Linear Systems with Saturating Actuators*,
    Springer 2011, Lemma 1.6 / Ch. 3): for x with ``|(K - G) x| <= u0``,
    ``psi' T (psi - G x) <= 0`` for any ``T > 0`` (diagonal).  With ``W = P^{-1}``,
    ``Z = G W``, ``S = T^{-1}`` the S-procedure gives the LMIs

    * ``[[A_cl W + W A_cl', -B S + Z'], [Z - S B', -2 S]] <= -eta I``  (decrease),
    * ``[[W, (K W - Z)'], [K W - Z, u0^2]] >= 0``  (ellipsoid inside the GSC region),
    * ``[[W, r v], [r v', 1]] >= 0``  (start ``x0 = r v`` inside ``x'Px <= 1``; ``v = e1 = [1, 0, 0]``,
      controller state 0, unless ``start`` says otherwise),

    and ``r`` is maximised: the largest initial displacement from rest (with
    ``z(0) = 0``) that is certified to converge.  A Hurwitz ``A_cl`` always has a
    positive ``r`` (a small enough level set of any Lyapunov function of ``A_cl``
    stays in the linear zone).

    The LMIs are solved in a scaled state, time and saturation unit
    (:func:`roa_scalings`; exact congruences); the scalings of ``scaling`` are
    tried in turn and the first answer that passes the numpy re-check in the
    *original* variables is returned, so the scaling changes how reliably the
    answer is found, never what it certifies.

    Parameters
    ----------
    loop
        The reduced loop.
    u0
        Acceleration limit of this axis [m/s^2] (:func:`axis_acceleration_limit`).
    axis
        ``'x'`` or ``'y'``.
    name
        Name of the result.
    r_cap
        Upper bound on the displacement [m] (keeps the problem bounded).
    scaling
        One name or a sequence of names of :data:`ROA_SCALINGS` (default: all,
        in that order); ``'none'`` is the unscaled problem.
    start
        The start state per metre of displacement ``v`` (position entry 1); default the
        loop's ``start_direction()`` (the NNI law: ``e1``, at rest with controller state 0;
        ``sni2``: ``[1, 0, C(0), 0]``, its controller at its DC value).

    Returns
    -------
    LMIResult
        ``matrices['P']`` the ellipsoid, ``values['max_displacement_m']`` = r (m),
        ``values['u0']`` the per-axis acceleration limit (m/s^2).
    """
    A0, B, Kc = loop.saturation_split(axis)
    A_cl = A0 + B @ Kc
    as_data(name, A=A_cl, u0=np.array([u0]))
    if u0 <= 0:
        raise GainError(f"acceleration limit must be positive, got {u0}")
    names = (scaling,) if isinstance(scaling, str) else tuple(scaling)
    table = roa_scalings(A_cl, B, Kc, u0)
    unknown = [s for s in names if s not in table]
    if unknown or not names:
        raise GainError(f"scaling must be one or more of {', '.join(ROA_SCALINGS)}; got {scaling!r}")
    n = A_cl.shape[0]
    v = np.asarray(loop.start_direction() if start is None else start, float).ravel()
    if v.shape != (n,) or v[0] != 1.0 or not np.all(np.isfinite(v)):
        raise GainError(f"start direction must be {n} finite numbers with position entry 1, got {v.tolist()}")
    data = {"A_cl": A_cl, "B": B, "K": Kc, "start": v.reshape(n, 1)}
    note = (f"generalised sector condition, saturation at u0 = {u0:.4g} m/s^2; "
            "ellipsoid x'Px <= 1 invariant and attractive; margin = max initial displacement from rest (m)")
    last: LMIResult | None = None
    error: SolverError | None = None
    for label in names:
        d, omega, psi = table[label]
        # eta: strictness of the decrease LMI, relative to the scaled problem's O(1) numbers
        # (1e-7 absolute in the original variables, as before, when unscaled)
        eta = 1e-7 if label == "none" else 1e-6
        try:
            status, answer = _roa_scaled(A_cl, B, Kc, u0, d, omega, psi, r_cap, eta, name, v)
        except SolverError as exc:
            error = exc
            continue
        if answer is None:
            last = result_fail(name, status, data, note + f"; solver: {status} (scaling {label})", K.RTOL,
                               values={"u0": u0})
            continue
        last = _roa_recheck(name, status, answer, data, u0, r_cap, note + f"; scaling {label}")
        if last.feasible:
            return last
    if last is None:
        assert error is not None
        raise error
    return last


def _roa_recheck(name: str, status: str, answer, data: dict[str, np.ndarray], u0: float, r_cap: float,
                 note: str) -> LMIResult:
    """The numpy re-check of one answer ``(W, Z, S, r)`` in the original variables (:func:`region_of_attraction`)."""
    A_cl, B, Kc, e1 = data["A_cl"], data["B"], data["K"], data["start"]
    Wv, Zv, Sv, rv = answer
    if not (np.all(np.isfinite(Wv)) and np.all(np.isfinite(Zv)) and np.all(np.isfinite(Sv))) or K.eigmin(Wv) <= 0 \
            or Sv[0, 0] == 0:
        return LMIResult(name, False, status, {"W": Wv, **data}, {}, rv, K.RTOL,
                         note + "; solver reported a solution but the numpy re-check failed", {"u0": u0})
    Pv = K.sym(np.linalg.inv(Wv))
    Gv = Zv @ Pv
    # numpy re-check in the original (P, G, T) variables
    T = np.linalg.inv(Sv)
    dec_rel, dec_bound = K.roa_decrease_margin(A_cl, B, Pv, Gv, T)
    definite, definite_bound = K.definite_margin(Pv)
    res = {
        "min_eig_W": K.eigmin(Wv) / K.norm(Wv),
        "decrease_max_eig_W": K.eigmax(np.block([[A_cl @ Wv + Wv @ A_cl.T, -B @ Sv + Zv.T], [Zv - Sv @ B.T, -2 * Sv]])),
        "decrease_max_eig_P": dec_rel,
        "decrease_rounding_bound": dec_bound,
        "min_eig_P_scaled": definite,
        "definite_rounding_bound": definite_bound,
        "inclusion_margin": K.roa_inclusion_margin(Kc, Gv, Wv, u0),
        "x0_level": K.ellipsoid_level(Pv, rv * e1),
    }
    # strict inequalities with a margin above rounding (nniquad.analysis.lmi.checks)
    ok = (res["min_eig_W"] > 0 and res["decrease_max_eig_W"] < 0 and dec_rel < -dec_bound and definite > definite_bound
          and res["inclusion_margin"] >= -K.RTOL and res["x0_level"] <= 1 + 1e-5 and T[0, 0] > 0)
    if rv >= 0.999 * r_cap:
        note += "; displacement hit its cap"
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    values = {"max_displacement_m": rv, "u0": u0}
    return LMIResult(name, ok, status, {"P": Pv, "W": Wv, "G": Gv, "T": T, **data}, res, rv, K.RTOL, note, values)


def certified_region(loop: ReducedLoop, tilt_limit_deg: float = TILT_LIMIT_DEG) -> list[LMIResult]:
    """The region-of-attraction LMIs of a loop under its tilt limit: one result, or one per axis.

    Equal axis gains: one result ``region_of_attraction[x]`` with the norm limit
    ``g tan(tilt)`` (rotation-invariant ellipsoid, see
    :func:`axis_acceleration_limit`).  Different axis gains: one result per axis
    with the inscribed limit ``g tan(tilt)/sqrt(2)``.  Each result's ``values``
    also hold ``tilt_limit_deg`` and ``norm_model`` (1.0 or 0.0).

    Parameters
    ----------
    loop
        The reduced loop (its ``g`` sets the acceleration limit).
    tilt_limit_deg
        Tilt limit [deg].

    Raises
    ------
    SolverError
        If the solver fails (see :func:`certified_reach` for the tolerant form).
    """
    axes = loop.axes
    u0 = axis_acceleration_limit(loop.g, tilt_limit_deg, "norm" if len(axes) == 1 else "inscribed")
    out = []
    for label, _ in axes:
        roa = region_of_attraction(loop, u0, axis=label, name=f"region_of_attraction[{label}]")
        roa.values["tilt_limit_deg"] = tilt_limit_deg
        roa.values["norm_model"] = float(len(axes) == 1)
        out.append(roa)
    return out


def _reach(results: Sequence[LMIResult]) -> list[float]:
    return [float(r.values.get("max_displacement_m", 0.0)) if r.feasible else 0.0 for r in results]


def start_certified(roa_results: Sequence[LMIResult], xi0: Sequence[float] = XI0_M) -> bool:
    """Whether the displacement ``xi0`` (m, from rest, controller state 0) lies in the certified region.

    One result (equal axis gains, norm model): ``‖xi0‖ <= max_displacement_m``.
    Two results (per-axis, inscribed box model): each coordinate within its axis's reach.

    Parameters
    ----------
    roa_results
        The results of :func:`certified_region`.
    xi0
        Initial horizontal position [m].
    """
    reach = _reach(roa_results)
    if not reach:
        return False
    if len(reach) == 1:
        return math.hypot(*xi0) <= reach[0]
    return all(abs(v) <= rr for v, rr in zip(xi0, reach))


def reach_of(roa_results: Sequence[LMIResult]) -> float:
    """The certified reach [m] of :func:`certified_region`'s results: the smallest axis reach, 0 if none."""
    reach = _reach(roa_results)
    return min(reach) if reach else 0.0


def certified_reach(loop: ReducedLoop, tilt_limit_deg: float = TILT_LIMIT_DEG) -> float:
    """Largest displacement from rest that the saturation region-of-attraction LMI certifies [m].

    The one definition of the certified reach (the tuner, the certificate, the
    ``lmi`` command and the notebooks use it): :func:`reach_of` of
    :func:`certified_region`.  0 when nothing is certified, including when the
    solver fails on a badly conditioned instance (extreme gains): an answer the
    solver could not give certifies nothing.

    Parameters
    ----------
    loop
        The reduced loop.
    tilt_limit_deg
        Tilt limit [deg].
    """
    try:
        return reach_of(certified_region(loop, tilt_limit_deg))
    except SolverError:
        return 0.0
