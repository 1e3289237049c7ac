"""Time-optimal lower bound on horizontal settling under the tilt limit.

No controller can settle faster than the vehicle's physics allow.  Holding
altitude with the body tilted by ``ϑ`` gives a horizontal acceleration of
``g tan ϑ``, so a tilt limit ``ϑ_max`` limits ``‖a_h‖ <= a_max = g tan ϑ_max``
(and the thrust limit caps the tilt at ``arccos(m g / T_max)``; the smaller
of the two tilts is used).  With the horizontal dynamics reduced to a double
integrator ``ξ̈_h = a_h`` (attitude assumed instantaneous, which only makes
the bound lower), this module computes the minimum time from ``ξ_h(0)`` at rest
into the settling band of radius ``r = band_fraction · ‖ξ_h(0)‖`` in two senses:

``rest_to_rest``
    The vehicle ends at rest inside the band.
``enter_band``
    The vehicle enters the band at a speed from which it can stay inside:
    braking in a straight line at ``a_max`` from ``(ξ_f, v_f)`` stops at
    ``ξ_f + v_f ‖v_f‖ / (2 a_max)``; both ends of that segment inside the
    (convex) band keep the whole stop inside.  This is the bound that matches
    the settling definition (last exit from the band), so tuned settling times
    are reported as a ratio to it.

Both are solved as free-final-time optimal control problems with CasADi's
``Opti`` and IPOPT in scaled (dimensionless) variables, and checked against the
closed forms of straight-line bang-bang motion, :func:`bang_bang_rest_to_rest`
and :func:`bang_bang_enter_band`.

Why the 2-D optimum is the straight line: projecting any admissible 2-D motion
onto the initial direction ``e0`` gives an admissible 1-D motion (``|a·e0| <=
‖a‖``) whose end state satisfies the 1-D version of each terminal condition, so
the 1-D minimum time is a lower bound, and the straight line attains it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from nniquad.config import TILT_LIMIT_DEG, XI0_M
from nniquad.errors import SimulationError, SolverError
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle
from nniquad.sim.metrics import DEFAULT_BAND_FRACTION

__all__ = [
    "BoundTrajectory",
    "BoundResult",
    "bang_bang_rest_to_rest",
    "bang_bang_enter_band",
    "max_horizontal_acceleration",
    "thrust_tilt_limit_deg",
    "time_optimal_bound",
    "DEFAULT_XI0",
    "DEFAULT_TILT_LIMIT_DEG",
    "DEFAULT_N_INTERVALS",
]

#: Paper's initial horizontal position [m] (:data:`nniquad.config.XI0_M`).
DEFAULT_XI0: tuple[float, float] = XI0_M
#: Default tilt limit [deg] (:data:`nniquad.config.TILT_LIMIT_DEG`).
DEFAULT_TILT_LIMIT_DEG = TILT_LIMIT_DEG
#: Control intervals of the transcription; the discrete optimum is above the
#: continuous one by O(h²), about 1e-5 relative at 200 intervals.
DEFAULT_N_INTERVALS = 200


# ---------------------------------------------------------------------------
# closed forms


def bang_bang_rest_to_rest(D: float, r: float, a_max: float) -> float:
    """Minimum time [s] from rest at distance ``D`` to rest on the band edge ``r``.

    Accelerate at ``a_max`` for half the distance ``L = D - r``, brake for the
    other half: ``t = 2 sqrt(L / a_max)`` (``0`` when already inside).

    Parameters
    ----------
    D
        Initial distance from the origin [m].
    r
        Band radius [m].
    a_max
        Acceleration limit [m/s²].
    """
    L = max(D - r, 0.0)
    return 2.0 * math.sqrt(L / a_max)


def bang_bang_enter_band(D: float, r: float, a_max: float) -> float:
    """Minimum time [s] from rest at distance ``D`` into the band with a stoppable speed.

    On the line to the origin, entering at ``s = r`` with speed ``v`` the vehicle
    can stop before the far edge ``s = -r`` iff ``v² <= 2 a_max (2 r)``, so the
    fastest admissible entry speed is ``w = sqrt(4 a_max r)``.  Covering
    ``L = D - r`` from rest to speed ``w`` as fast as possible:

    * if full acceleration reaches at most ``w`` (``2 a_max L <= w²``, i.e.
      ``D <= 3 r``): ``t = sqrt(2 L / a_max)``;
    * otherwise accelerate to the peak speed ``V`` then brake to ``w``, with
      ``V²/(2a) + (V² - w²)/(2a) = L`` so ``V = sqrt(a_max L + w²/2)`` and
      ``t = (2 V - w) / a_max``.

    Equivalently ``t = 2 sqrt((D + r)/a_max) - 2 sqrt(r / a_max)``: the
    rest-to-rest motion to the far edge, minus its final braking inside the band.

    Parameters
    ----------
    D
        Initial distance from the origin [m].
    r
        Band radius [m].
    a_max
        Acceleration limit [m/s²].
    """
    L = D - r
    if L <= 0.0:
        return 0.0
    w2 = 4.0 * a_max * r
    if 2.0 * a_max * L <= w2:
        return math.sqrt(2.0 * L / a_max)
    V = math.sqrt(a_max * L + 0.5 * w2)
    return (2.0 * V - math.sqrt(w2)) / a_max


def thrust_tilt_limit_deg(vehicle: Vehicle) -> float:
    """Largest tilt [deg] at which full thrust still holds altitude, ``arccos(m g / T_max)``."""
    return math.degrees(math.acos(1.0 / vehicle.thrust_to_weight()))


def max_horizontal_acceleration(vehicle: Vehicle, tilt_limit_deg: float) -> float:
    """``a_max = g tan(min(tilt_limit, thrust tilt limit))`` [m/s²] at constant altitude.

    Parameters
    ----------
    vehicle
        Supplies ``g`` and the thrust limit.
    tilt_limit_deg
        Tilt limit [deg].
    """
    tilt = min(float(tilt_limit_deg), thrust_tilt_limit_deg(vehicle))
    return vehicle.g * math.tan(math.radians(tilt))


# ---------------------------------------------------------------------------
# results


@dataclass(frozen=True)
class BoundTrajectory:
    """An optimal trajectory of the bound problem (SI units).

    Attributes
    ----------
    t
        Node times [s], shape ``(N + 1,)``.
    xy
        Horizontal positions [m], shape ``(N + 1, 2)``.
    v
        Horizontal velocities [m/s], shape ``(N + 1, 2)``.
    a
        Horizontal acceleration [m/s²] held on each interval, shape ``(N, 2)``.
    """

    t: NDArray[np.float64]
    xy: NDArray[np.float64]
    v: NDArray[np.float64]
    a: NDArray[np.float64]

    def to_json(self) -> dict[str, Any]:
        """Plain lists."""
        return {"t_s": self.t.tolist(), "xy_m": self.xy.tolist(), "v_m_s": self.v.tolist(), "a_m_s2": self.a.tolist()}


@dataclass(frozen=True)
class BoundResult:
    """Time-optimal bounds on settling, their closed forms and the optimal motions.

    Attributes
    ----------
    vehicle_name
        Label of the vehicle.
    xi0_m
        Initial horizontal position [m].
    distance_m
        ``‖ξ_h(0)‖`` [m].
    band_fraction, band_radius_m
        Settling band as a fraction of ``distance_m`` and its radius [m].
    tilt_limit_deg
        Requested tilt limit [deg].
    thrust_tilt_limit_deg
        Tilt [deg] beyond which full thrust cannot hold altitude.
    effective_tilt_limit_deg
        The smaller of the two [deg], used for ``a_max_m_s2``.
    a_max_m_s2
        Horizontal acceleration limit [m/s²].
    rest_to_rest_s, enter_band_s
        IPOPT optimum of each case [s].
    rest_to_rest_closed_form_s, enter_band_closed_form_s
        Straight-line bang-bang closed forms [s].
    n_intervals
        Control intervals of the transcription.
    solver
        Per case: IPOPT return status, iterations, wall time [s].
    trajectories
        Per case: the optimal :class:`BoundTrajectory`.
    """

    vehicle_name: str
    xi0_m: tuple[float, float]
    distance_m: float
    band_fraction: float
    band_radius_m: float
    tilt_limit_deg: float
    thrust_tilt_limit_deg: float
    effective_tilt_limit_deg: float
    a_max_m_s2: float
    rest_to_rest_s: float
    enter_band_s: float
    rest_to_rest_closed_form_s: float
    enter_band_closed_form_s: float
    n_intervals: int
    solver: dict[str, dict[str, Any]] = field(default_factory=dict)
    trajectories: dict[str, BoundTrajectory] = field(default_factory=dict)

    @property
    def rest_to_rest_rel_error(self) -> float:
        """``(IPOPT - closed form) / closed form`` for the rest-to-rest case."""
        return (self.rest_to_rest_s - self.rest_to_rest_closed_form_s) / self.rest_to_rest_closed_form_s

    @property
    def enter_band_rel_error(self) -> float:
        """``(IPOPT - closed form) / closed form`` for the enter-band case."""
        return (self.enter_band_s - self.enter_band_closed_form_s) / self.enter_band_closed_form_s

    def __repr__(self) -> str:
        return (f"BoundResult(enter_band_s={self.enter_band_s:.4g} s, rest_to_rest_s={self.rest_to_rest_s:.4g} s, "
                f"a_max={self.a_max_m_s2:.4g} m/s^2 at tilt {self.effective_tilt_limit_deg:.4g} deg, "
                f"|xi0|={self.distance_m:.4g} m, vehicle={self.vehicle_name!r})")

    def ratio(self, settling_s: float | None) -> float | None:
        """A settling time as a multiple of ``enter_band_s`` (``None`` if not settled).

        Parameters
        ----------
        settling_s
            A settling time [s], or ``None`` (did not settle).
        """
        return None if settling_s is None else float(settling_s) / self.enter_band_s

    def to_json(self, *, include_trajectories: bool = True) -> dict[str, Any]:
        """Plain dict with units in the key names.

        Parameters
        ----------
        include_trajectories
            Also include the optimal motions (time, position, velocity, acceleration).
        """
        out: dict[str, Any] = {
            "vehicle": self.vehicle_name,
            "xi0_m": list(self.xi0_m),
            "distance_m": self.distance_m,
            "band_fraction": self.band_fraction,
            "band_radius_m": self.band_radius_m,
            "tilt_limit_deg": self.tilt_limit_deg,
            "thrust_tilt_limit_deg": self.thrust_tilt_limit_deg,
            "effective_tilt_limit_deg": self.effective_tilt_limit_deg,
            "a_max_m_s2": self.a_max_m_s2,
            "rest_to_rest_s": self.rest_to_rest_s,
            "enter_band_s": self.enter_band_s,
            "rest_to_rest_closed_form_s": self.rest_to_rest_closed_form_s,
            "enter_band_closed_form_s": self.enter_band_closed_form_s,
            "rest_to_rest_rel_error": self.rest_to_rest_rel_error,
            "enter_band_rel_error": self.enter_band_rel_error,
            "n_intervals": self.n_intervals,
            "solver": self.solver,
        }
        if include_trajectories:
            out["trajectories"] = {k: v.to_json() for k, v in self.trajectories.items()}
        return out


# ---------------------------------------------------------------------------
# optimal control


def _check(xi0: Sequence[float], tilt_limit_deg: float, band_fraction: float, n_intervals: int) -> NDArray[np.float64]:
    try:
        x = np.asarray([float(v) for v in xi0], dtype=float)
    except (TypeError, ValueError):
        raise SimulationError(f"xi0 must be two numbers in m, got {xi0!r}") from None
    if x.shape != (2,):
        raise SimulationError(f"xi0 must be two numbers in m, got {len(x)}")
    if not np.all(np.isfinite(x)):
        raise SimulationError(f"xi0 must be finite, got ({x[0]}, {x[1]}) m")
    if not np.hypot(*x) > 0:
        raise SimulationError("xi0 must not be the origin: there is nothing to settle")
    try:
        tl = float(tilt_limit_deg)
    except (TypeError, ValueError):
        raise SimulationError(f"tilt limit must be a number in deg, got {tilt_limit_deg!r}") from None
    if not (math.isfinite(tl) and 0.0 < tl < 90.0):
        raise SimulationError(f"tilt limit must be strictly between 0 and 90 deg, got {tilt_limit_deg!r}")
    bf = float(band_fraction)
    if not (math.isfinite(bf) and 0.0 < bf < 1.0):
        raise SimulationError(f"band fraction must be strictly between 0 and 1, got {band_fraction!r}")
    if isinstance(n_intervals, bool) or int(n_intervals) != n_intervals or n_intervals < 2:
        raise SimulationError(f"n_intervals must be an integer >= 2, got {n_intervals!r}")
    return x


def _solve(case: str, p0: NDArray[np.float64], rbar: float, n: int) -> tuple[float, dict[str, Any], tuple]:
    """Solve one case in units of length D, acceleration a_max, time sqrt(D / a_max).

    In these units every variable is O(1), which IPOPT needs for tight
    tolerances.  Piecewise-constant acceleration makes the double-integrator
    step exact, so the only error is that the switching instant is not a node.
    """
    import casadi as ca  # heavy import, only when the bound is computed

    opti = ca.Opti()
    T = opti.variable()
    P = opti.variable(2, n + 1)
    V = opti.variable(2, n + 1)
    U = opti.variable(2, n)
    h = T / n
    opti.minimize(T)
    opti.subject_to(P[:, 0] == p0)
    opti.subject_to(V[:, 0] == 0)
    opti.subject_to(P[:, 1:] == P[:, :-1] + h * V[:, :-1] + 0.5 * h**2 * U)
    opti.subject_to(V[:, 1:] == V[:, :-1] + h * U)
    opti.subject_to(ca.sum1(U**2) <= 1)
    opti.subject_to(opti.bounded(0.05, T, 100.0))
    pf, vf = P[:, n], V[:, n]
    # Divide by rbar² so the constraint is O(1): IPOPT relaxes inequality bounds
    # by ~1e-8 absolute, which on rbar² = 4e-4 would let the end point sit
    # 1e-5 (relative) outside the band.
    opti.subject_to(ca.sumsqr(pf) / rbar**2 <= 1)
    if case == "rest_to_rest":
        opti.subject_to(vf == 0)
    else:
        # Stopping point of straight-line braking: pf + vf |vf| / 2 (a_max = 1).
        # The tiny epsilon keeps |vf| differentiable; the optimum has |vf| ~ 0.4.
        speed = ca.sqrt(ca.sumsqr(vf) + 1e-14)
        opti.subject_to(ca.sumsqr(pf + 0.5 * speed * vf) / rbar**2 <= 1)

    # Neutral initial guess (not the closed form): straight line at constant speed.
    T0 = 3.0
    s = np.linspace(0.0, 1.0, n + 1)
    opti.set_initial(T, T0)
    opti.set_initial(P, np.outer(p0, 1.0 - s))
    opti.set_initial(V, np.outer(-p0 / T0, np.ones(n + 1)))
    opti.set_initial(U, np.zeros((2, n)))
    opti.solver(
        "ipopt",
        {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-10, "ipopt.max_iter": 1000},
    )
    t0 = time.perf_counter()
    try:
        sol = opti.solve()
    except RuntimeError as exc:
        status = opti.stats().get("return_status", "unknown")
        raise SolverError(f"IPOPT failed on the {case} bound problem: {status} ({exc})") from None
    wall = time.perf_counter() - t0
    stats = opti.stats()
    info = {
        "return_status": str(stats.get("return_status")),
        "iterations": int(stats.get("iter_count", -1)),
        "wall_time_s": wall,
    }
    return float(sol.value(T)), info, (np.asarray(sol.value(P)), np.asarray(sol.value(V)), np.asarray(sol.value(U)))


def time_optimal_bound(
    vehicle: Vehicle = PAPER_VEHICLE,
    xi0: Sequence[float] = DEFAULT_XI0,
    tilt_limit_deg: float = DEFAULT_TILT_LIMIT_DEG,
    band_fraction: float = DEFAULT_BAND_FRACTION,
    n_intervals: int = DEFAULT_N_INTERVALS,
) -> BoundResult:
    """Minimum time into the settling band with the horizontal acceleration tilt-limited.

    Parameters
    ----------
    vehicle
        Supplies ``g`` and the thrust limit.
    xi0
        Initial horizontal position [m]; the vehicle starts at rest.
    tilt_limit_deg
        Tilt limit [deg], strictly between 0 and 90.
    band_fraction
        Band radius as a fraction of ``‖xi0‖`` (2 % by default, as for settling).
    n_intervals
        Control intervals of the direct transcription.

    Returns
    -------
    BoundResult
        Both bounds from IPOPT, their closed forms and the optimal trajectories.

    Raises
    ------
    SimulationError
        On invalid options (tilt limit outside (0, 90) deg, ``xi0`` at the origin
        or non-finite, ...).
    SolverError
        If IPOPT does not converge.
    """
    x0 = _check(xi0, tilt_limit_deg, band_fraction, n_intervals)
    n = int(n_intervals)
    D = float(np.hypot(*x0))
    r = float(band_fraction) * D
    thrust_tilt = thrust_tilt_limit_deg(vehicle)
    eff_tilt = min(float(tilt_limit_deg), thrust_tilt)
    a_max = vehicle.g * math.tan(math.radians(eff_tilt))
    t_scale = math.sqrt(D / a_max)
    v_scale = math.sqrt(D * a_max)

    times: dict[str, float] = {}
    solver: dict[str, dict[str, Any]] = {}
    trajs: dict[str, BoundTrajectory] = {}
    for case in ("rest_to_rest", "enter_band"):
        Tbar, info, (P, V, U) = _solve(case, x0 / D, float(band_fraction), n)
        T = Tbar * t_scale
        times[case] = T
        solver[case] = info
        trajs[case] = BoundTrajectory(
            t=np.linspace(0.0, T, n + 1), xy=P.T * D, v=V.T * v_scale, a=U.T * a_max
        )
    return BoundResult(
        vehicle_name=vehicle.name,
        xi0_m=(float(x0[0]), float(x0[1])),
        distance_m=D,
        band_fraction=float(band_fraction),
        band_radius_m=r,
        tilt_limit_deg=float(tilt_limit_deg),
        thrust_tilt_limit_deg=thrust_tilt,
        effective_tilt_limit_deg=eff_tilt,
        a_max_m_s2=a_max,
        rest_to_rest_s=times["rest_to_rest"],
        enter_band_s=times["enter_band"],
        rest_to_rest_closed_form_s=bang_bang_rest_to_rest(D, r, a_max),
        enter_band_closed_form_s=bang_bang_enter_band(D, r, a_max),
        n_intervals=n,
        solver=solver,
        trajectories=trajs,
    )
