"""One check for every number a user gives: finite, a real number, optionally positive.

Each layer raises its own error class (``GainError`` for gains,
``SimulationError`` for simulation options, ...); the messages are the same
everywhere: "``name`` must be a number / finite / positive / not negative, got ...".
"""

from __future__ import annotations

import cmath
import math
from typing import Any, Mapping

from nniquad.config import RK4_STEP_LIMIT
from nniquad.errors import NniquadError

__all__ = ["finite_number", "finite_int", "inner_loop_poles", "check_rk4_step"]


def finite_number(name: str, value: Any, *, error: type[NniquadError] = NniquadError, positive: bool = False,
                  nonneg: bool = False) -> float:
    """``value`` as a finite float, else ``error`` naming ``name``.

    Parameters
    ----------
    name
        What the value is, for the message.
    value
        The user's value (booleans are refused: ``True`` is not a gain).
    error
        Exception class to raise.
    positive, nonneg
        Also require ``> 0`` or ``>= 0``.
    """
    if isinstance(value, bool):
        raise error(f"{name} must be a number, got {_short(value)}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise error(f"{name} must be a number, got {_short(value)}") from None
    except OverflowError:  # an int beyond the float range
        raise error(f"{name} must be finite, got an integer beyond the float range") from None
    if not math.isfinite(v):
        raise error(f"{name} must be finite, got {_short(value)}")
    if positive and v <= 0:
        raise error(f"{name} must be positive, got {_short(value)}")
    if nonneg and v < 0:
        raise error(f"{name} must not be negative, got {_short(value)}")
    return v


def _short(value: Any, limit: int = 60) -> str:
    try:
        text = repr(value)
    except ValueError:  # an int beyond Python's int-to-str limit
        return f"a {type(value).__name__} too long to print"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def finite_int(name: str, value: Any, *, error: type[NniquadError] = NniquadError, minimum: int | None = None,
               maximum: int | None = None) -> int:
    """``value`` as an int in ``[minimum, maximum]``, else ``error`` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int):
        try:
            f = float(value)
        except (TypeError, ValueError, OverflowError):
            raise error(f"{name} must be an integer, got {_short(value)}") from None
        if not (math.isfinite(f) and f == int(f)):
            raise error(f"{name} must be an integer, got {_short(value)}")
        value = int(f)
    if minimum is not None and value < minimum:
        raise error(f"{name} must be at least {minimum}, got {_short(value)}")
    if maximum is not None and value > maximum:
        raise error(f"{name} must be at most {maximum}, got {_short(value)}")
    return int(value)


def _second_order_pole(wn: float, zeta: float, scale: float = 1.0) -> float:
    """Largest ``|lambda|`` of ``lambda^2 + 2 zeta wn s lambda + s wn^2`` (a PD loop whose torque is scaled by s)."""
    b, c = 2.0 * zeta * wn * scale, scale * wn * wn
    root = cmath.sqrt(b * b - 4.0 * c)
    return max(abs((-b + root) / 2.0), abs((-b - root) / 2.0))


def inner_loop_poles(inner: Any, *, attitude_gain_scale: float | None = None,
                     tau_motor_s: float | None = None) -> dict[str, float]:
    """Magnitudes ``|lambda|`` [1/s] of the inner-loop poles near hover (see :mod:`nniquad.control.inner_loops`).

    Parameters
    ----------
    inner
        An :class:`nniquad.control.inner_gains.InnerLoopGains` (read by attribute).
    attitude_gain_scale
        Factor on the attitude torques (default: ``inner.attitude_gain_scale``);
        a Monte Carlo study passes the top of its range.
    tau_motor_s
        Motor time constant when motor lag is on (pole ``-1/tau``), else ``None``.

    Returns
    -------
    dict
        ``{"attitude": ..., "yaw": ..., "altitude": ..., ["motor lag": ...]}``.
    """
    s = float(inner.attitude_gain_scale if attitude_gain_scale is None else attitude_gain_scale)
    poles = {
        "attitude": _second_order_pole(inner.attitude_wn_rad_s, inner.attitude_zeta, s),
        "yaw": _second_order_pole(inner.yaw_wn_rad_s, inner.yaw_zeta, s),
        "altitude": float(inner.altitude_wn_rad_s),  # triple pole at -omega_z
    }
    if tau_motor_s is not None:
        poles["motor lag"] = 1.0 / float(tau_motor_s)
    return poles


def check_rk4_step(poles: Mapping[str, float], dt_s: float, *, error: type[NniquadError] = NniquadError,
                   hint: str | Mapping[str, str] = "") -> None:
    """Refuse a step ``dt_s`` that makes RK4 unstable (or inaccurate) for the fastest pole.

    The stability region of classical RK4 contains every left-half-plane
    ``z = lambda dt`` with ``|z| <= 2.61`` (2.785 on the negative real axis,
    2.83 on the imaginary axis), so ``|lambda| dt <=``
    :data:`nniquad.config.RK4_STEP_LIMIT` (2.5) is sufficient for any stable
    pole.  The simulator applies it to every pole of a run
    (:func:`nniquad.sim.step_check.check_step`); a non-finite pole is refused too.

    Parameters
    ----------
    poles
        Name -> ``|lambda|`` [1/s] (:func:`inner_loop_poles`, :func:`nniquad.sim.step_check.run_poles`).
    dt_s
        The RK4 step [s].
    hint
        The option to change, for the message ("--attitude-wn"), or one per pole name.
    """
    if not poles:  # e.g. a PD law with the true velocity on a point-mass model: nothing but the plant
        return
    # a non-finite pole first: max() over a nan compares False both ways and could pass it over
    name, fastest = next(((n, v) for n, v in poles.items() if not math.isfinite(v)), None) or max(
        poles.items(), key=lambda kv: kv[1])
    if not isinstance(hint, str):
        hint = hint.get(name, "")
    change = f"; change {hint}" if hint else ""
    if not math.isfinite(fastest):
        raise error(f"the {name} pole is not finite (|lambda| = {fastest}): no time step can integrate it{change}")
    if not fastest * dt_s <= RK4_STEP_LIMIT:
        raise error(
            f"time step {dt_s:g} s too large for the {name} pole |lambda| = {fastest:.4g} 1/s "
            f"(RK4 needs |lambda| dt <= {RK4_STEP_LIMIT:g}, so at most {RK4_STEP_LIMIT / fastest:.3g} s){change}"
        )
