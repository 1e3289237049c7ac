"""Performance metrics of closed-loop runs: one definition of each.

Simulation, tuning, certificates and notebooks all call these functions, so a
"settling time" means the same number everywhere.  The conventions come from
the design notes (``DESIGN.md``):

* **Settling time** -- the last time the horizontal distance ``‖ξ_h(t)‖`` is
  outside the band of ``band_fraction`` (2 %) of ``‖ξ_h(0)‖``, linearly
  interpolated between the two samples around that exit; ``None`` when the run
  ends outside the band ("did not settle"), ``0.0`` when it never leaves it.
* **Overshoot** -- the largest excursion past the origin along the initial
  direction ``e0 = ξ_h(0)/‖ξ_h(0)‖``, ``max_t(-⟨ξ_h(t), e0⟩)`` clipped at 0, in
  percent of ``‖ξ_h(0)‖``.
* **Steady offset** -- the mean distance ``‖ξ_h‖`` from the setpoint over the
  last :data:`nniquad.config.STEADY_OFFSET_WINDOW_S` (1 s) of the run
  (:func:`steady_offset_m`): what a constant force leaves behind.
* **Tilt** -- the total tilt angle ``arccos(cos φ cos θ)`` in degrees.
* **Noise budget** -- the RMS of the commanded tilt over the run's hover window
  (:func:`hover_window_start_s`: from the settling time on, the whole run for a
  run that starts at the setpoint) and the share of samples with any commanded
  rotor speed at a limit, 0 or ``ω_max`` (:func:`rotor_limit_share`).
* **Blew up** -- a non-finite sample (position or altitude), or a horizontal
  distance beyond ``DIVERGENCE_FACTOR`` (100) times the run's scale, by
  default ``‖ξ_h(0)‖`` (1 m for a run that starts at the origin).
* **Altitude lost** -- an altitude deviation beyond ``ALTITUDE_LIMIT_M`` (2 m)
  from the reference, or a non-finite altitude (``full`` runs only).
* **Diverged** -- the vehicle is lost: it blew up or lost its altitude (the
  ``diverged`` flag of every report).
* **Failure** -- the first of "diverged" (blew up), "altitude lost", "not
  settled" that applies (:func:`failure_reason`); ``simulate``, ``tune`` and
  the Monte Carlo study all read their verdicts from
  :mod:`nniquad.sim.verdicts` (:func:`diverged_batch`,
  :func:`blew_up_batch`, :func:`altitude_lost_batch`, :func:`failure_reason`).

All functions are pure and take numpy arrays: time ``t`` [s] of shape ``(N,)``,
horizontal positions ``xy`` [m] of shape ``(N, 2)``.  The ``*_batch`` variants
take ``(B, N, 2)`` and are vectorised, because a tuner scores hundreds of
trajectories per iteration.  Time-weighted quantities use the trapezoidal rule,
so non-uniform (adaptive-step) samples are handled correctly.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nniquad.config import BAND_FRACTION, DIVERGENCE_FACTOR, STEADY_OFFSET_WINDOW_S
from nniquad.errors import SimulationError

__all__ = [
    "DEFAULT_BAND_FRACTION",
    "DEFAULT_DIVERGENCE_FACTOR",
    "settling_time",
    "settling_time_batch",
    "overshoot_pct",
    "overshoot_pct_batch",
    "tilt_deg",
    "peak_tilt_deg",
    "time_on_limit_fraction",
    "steady_offset_m",
    "hover_window_start_s",
    "rotor_limit_share",
    "rms_after",
    "peak_abs",
]

#: Settling band as a fraction of the initial distance (:data:`nniquad.config.BAND_FRACTION`).
DEFAULT_BAND_FRACTION = BAND_FRACTION
#: A run whose distance exceeds this multiple of its scale is diverged (:data:`nniquad.config.DIVERGENCE_FACTOR`).
DEFAULT_DIVERGENCE_FACTOR = DIVERGENCE_FACTOR


# ---------------------------------------------------------------------------
# input checks


def time_axis(t: ArrayLike) -> NDArray[np.float64]:
    ta = np.asarray(t, dtype=float)
    if ta.ndim != 1 or ta.size < 1:
        raise ValueError(f"time vector must be 1-D and non-empty, got shape {ta.shape}")
    if ta.size > 1 and np.any(np.diff(ta) < 0):
        raise ValueError("time vector must be non-decreasing")
    return ta


def points_batch(t: NDArray[np.float64], xy: ArrayLike, *, batched: bool) -> NDArray[np.float64]:
    a = np.asarray(xy, dtype=float)
    want = 3 if batched else 2
    if a.ndim != want or a.shape[-1] != 2:
        shape = "(B, N, 2)" if batched else "(N, 2)"
        raise ValueError(f"positions must have shape {shape}, got {a.shape}")
    if a.shape[-2] != t.size:
        raise ValueError(f"positions have {a.shape[-2]} samples but the time vector has {t.size}")
    return a if batched else a[None]


# ---------------------------------------------------------------------------
# settling and overshoot


def settling_time_batch(
    t: ArrayLike,
    xy_batch: ArrayLike,
    band_fraction: float = DEFAULT_BAND_FRACTION,
    reference_norm: float | ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Settling times of a batch of runs sharing one time vector.

    Parameters
    ----------
    t
        Sample times [s], shape ``(N,)``, non-decreasing.
    xy_batch
        Horizontal positions [m], shape ``(B, N, 2)``.
    band_fraction
        Band radius as a fraction of ``reference_norm``.
    reference_norm
        Distance [m] the band is relative to, scalar or shape ``(B,)``; default
        ``‖xy[:, 0]‖`` of each run.

    Returns
    -------
    ndarray
        Shape ``(B,)``: settling time [s] of each run, ``nan`` where the run ends
        outside the band (did not settle), ``0.0`` where it is never outside.

    Notes
    -----
    A non-finite sample counts as outside the band.  The crossing is linearly
    interpolated; for a convex decaying distance (e.g. an exponential) the chord
    lies above the curve, so the interpolated time is late by at most
    ``h²/8 · max|d''| / min|d'|`` over the crossing interval of length ``h``.
    """
    ta = time_axis(t)
    a = points_batch(ta, xy_batch, batched=True)
    d = np.hypot(a[..., 0], a[..., 1])  # (B, N)
    ref = d[:, 0] if reference_norm is None else np.broadcast_to(np.asarray(reference_norm, float), d[:, 0].shape)
    band = band_fraction * ref
    # `~(d <= band)` rather than `d > band`: NaN must count as outside.
    outside = ~(d <= band[:, None])
    n = d.shape[1]
    any_out = outside.any(axis=1)
    ends_out = outside[:, -1]
    k = n - 1 - np.argmax(outside[:, ::-1], axis=1)  # last outside sample
    k1 = np.minimum(k + 1, n - 1)
    rows = np.arange(d.shape[0])
    dk, dk1 = d[rows, k], d[rows, k1]
    tk, tk1 = ta[k], ta[k1]
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = (dk - band) / (dk - dk1)
    # A non-finite sample before re-entry gives no slope: take the first inside sample.
    frac = np.where(np.isfinite(frac), np.clip(frac, 0.0, 1.0), 1.0)
    ts = tk + frac * (tk1 - tk)
    out = np.where(any_out, ts, 0.0)
    out = np.where(ends_out, np.nan, out)
    return out


def settling_time(
    t: ArrayLike,
    xy: ArrayLike,
    band_fraction: float = DEFAULT_BAND_FRACTION,
    reference_norm: float | None = None,
) -> float | None:
    """Settling time of one run: last exit from the band around the origin.

    Parameters
    ----------
    t
        Sample times [s], shape ``(N,)``.
    xy
        Horizontal positions [m], shape ``(N, 2)``.
    band_fraction
        Band radius as a fraction of ``reference_norm`` (default 2 %).
    reference_norm
        Distance [m] the band is relative to; default ``‖xy[0]‖``.

    Returns
    -------
    float or None
        Time [s] after which the distance stays inside the band (interpolated),
        ``0.0`` if it never leaves the band, ``None`` if the run ends outside it.
    """
    ta = time_axis(t)
    value = settling_time_batch(ta, points_batch(ta, xy, batched=False), band_fraction, reference_norm)[0]
    return None if math.isnan(value) else float(value)


def overshoot_pct_batch(t: ArrayLike, xy_batch: ArrayLike) -> NDArray[np.float64]:
    """Overshoot [%] of a batch of runs, shape ``(B,)`` (see :func:`overshoot_pct`).

    ``nan`` for runs with a non-finite sample or a zero initial distance.
    """
    ta = time_axis(t)
    a = points_batch(ta, xy_batch, batched=True)
    d0 = np.hypot(a[:, 0, 0], a[:, 0, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        e0 = a[:, 0, :] / d0[:, None]
        proj = np.einsum("bnk,bk->bn", a, e0)
        past = np.maximum(np.max(-proj, axis=1), 0.0)
        pct = 100.0 * past / d0
    finite = np.all(np.isfinite(a), axis=(1, 2)) & (d0 > 0)
    return np.where(finite, pct, np.nan)


def overshoot_pct(t: ArrayLike, xy: ArrayLike) -> float:
    """Largest excursion past the origin along the initial direction, in % of ‖ξ_h(0)‖.

    Parameters
    ----------
    t
        Sample times [s], shape ``(N,)`` (only checked; overshoot is a sample maximum).
    xy
        Horizontal positions [m], shape ``(N, 2)``; ``xy[0]`` must be non-zero.

    Returns
    -------
    float
        ``100 · max(0, max_t -⟨ξ_h(t), e0⟩) / ‖ξ_h(0)‖`` with ``e0 = ξ_h(0)/‖ξ_h(0)‖``;
        ``nan`` if any sample is non-finite.  Motion across the initial line
        does not count: only the component along ``e0`` does.

    Raises
    ------
    SimulationError
        If the run starts at the origin (no initial direction).
    """
    ta = time_axis(t)
    a = points_batch(ta, xy, batched=False)
    if not np.hypot(*a[0, 0]) > 0:
        raise SimulationError("overshoot is undefined for a run starting at the origin")
    return float(overshoot_pct_batch(ta, a)[0])


# ---------------------------------------------------------------------------
# attitude and generic signals


def tilt_deg(phi: ArrayLike, theta: ArrayLike) -> NDArray[np.float64]:
    """Total tilt angle ``arccos(cos φ cos θ)`` in degrees.

    Parameters
    ----------
    phi, theta
        Roll and pitch [rad] (ZYX Euler angles), broadcastable arrays.

    Returns
    -------
    ndarray
        Tilt of the body z axis from the vertical [deg], in ``[0, 180]``.

    Notes
    -----
    Evaluated as ``atan2(sqrt(sin²φ + cos²φ sin²θ), cos φ cos θ)``, which equals
    the arccos form exactly but keeps full relative precision for small angles
    (``arccos`` near 1 loses about half the digits, ~1e-8 rad absolute).
    """
    p = np.asarray(phi, dtype=float)
    q = np.asarray(theta, dtype=float)
    cp = np.cos(p)
    s = np.sqrt(np.sin(p) ** 2 + (cp * np.sin(q)) ** 2)
    return np.degrees(np.arctan2(s, cp * np.cos(q)))


def peak_tilt_deg(phi: ArrayLike, theta: ArrayLike) -> float:
    """Largest total tilt [deg] over a run (``nan`` propagates)."""
    return float(np.max(tilt_deg(phi, theta)))


def time_on_limit_fraction(t: ArrayLike, value: ArrayLike, limit: float | ArrayLike, rel_tol: float = 1e-3) -> float:
    """Fraction of the run's duration during which ``|value|`` sits at its limit.

    Parameters
    ----------
    t
        Sample times [s], shape ``(N,)``.
    value
        The signal, shape ``(N,)`` (its magnitude is compared, so symmetric
        saturations count on both sides).
    limit
        The positive limit, scalar or shape ``(N,)``, same unit as ``value``.
    rel_tol
        A sample is "at the limit" when ``|value| >= limit · (1 - rel_tol)``;
        saturated signals from an integrator sit just below the limit.

    Returns
    -------
    float
        Time-weighted fraction in ``[0, 1]`` (trapezoidal rule on the indicator,
        so non-uniform steps are weighted by their length); for a single sample
        or a zero-length run, the fraction of samples at the limit.
    """
    ta = time_axis(t)
    v = np.abs(np.asarray(value, dtype=float))
    if v.shape != ta.shape:
        raise ValueError(f"signal has shape {v.shape} but the time vector has {ta.shape}")
    at = (v >= np.asarray(limit, float) * (1.0 - rel_tol)).astype(float)
    duration = ta[-1] - ta[0]
    if duration <= 0:
        return float(at.mean())
    return float(np.trapezoid(at, ta) / duration)


def rms_after(t: ArrayLike, signal: ArrayLike, t0: float | None, *, remove_mean: bool = False) -> float | None:
    """Time-weighted RMS of ``signal`` over ``t >= t0`` (e.g. tilt jitter after settling).

    Parameters
    ----------
    t
        Sample times [s], shape ``(N,)``.
    signal
        Shape ``(N,)``.
    t0
        Start of the window [s]; ``None`` (run did not settle) gives ``None``.
    remove_mean
        Subtract the window's time average first (jitter about an offset).

    Returns
    -------
    float or None
        RMS in the signal's unit; ``None`` when ``t0`` is ``None`` or no sample
        lies in the window; ``|signal|`` of the only sample if there is one.
    """
    if t0 is None:
        return None
    ta = time_axis(t)
    s = np.asarray(signal, dtype=float)
    if s.shape != ta.shape:
        raise ValueError(f"signal has shape {s.shape} but the time vector has {ta.shape}")
    mask = ta >= t0
    if not mask.any():
        return None
    tw, sw = ta[mask], s[mask]
    duration = tw[-1] - tw[0]
    if duration <= 0:
        return float(np.sqrt(np.mean((sw - sw.mean()) ** 2 if remove_mean else sw**2)))
    if remove_mean:
        sw = sw - np.trapezoid(sw, tw) / duration
    return float(np.sqrt(np.trapezoid(sw**2, tw) / duration))


def peak_abs(signal: ArrayLike) -> float:
    """Largest magnitude of a signal of any shape (``nan`` propagates)."""
    return float(np.max(np.abs(np.asarray(signal, dtype=float))))


# ---------------------------------------------------------------------------
# steady state and noise budget


def steady_offset_m(t: ArrayLike, xy: ArrayLike, window_s: float = STEADY_OFFSET_WINDOW_S) -> float:
    """Distance from the setpoint at the end of a run: the time average of ``‖ξ_h‖`` over its last ``window_s``.

    Parameters
    ----------
    t
        Sample times [s], shape ``(N,)``.
    xy
        Horizontal positions relative to the setpoint [m], shape ``(N, 2)``.
    window_s
        Length of the final window [s] (default 1 s): long enough to average
        position noise, short enough to be steady after settling.

    Returns
    -------
    float
        Mean distance [m] (trapezoidal rule); ``nan`` if a sample in the window is
        non-finite; the last distance for a run shorter than one sample step.
    """
    ta = time_axis(t)
    d = np.hypot(*points_batch(ta, xy, batched=False)[0].T)
    mask = ta >= ta[-1] - window_s
    tw, dw = ta[mask], d[mask]
    if tw[-1] - tw[0] <= 0:
        return float(dw[-1])
    return float(np.trapezoid(dw, tw) / (tw[-1] - tw[0]))


def hover_window_start_s(xy: ArrayLike, settling_s: float | None) -> float | None:
    """Start [s] of a run's hover window: where the noise budget is measured.

    A run that starts at the setpoint (``ξ_h(0) = 0``) hovers throughout (0.0);
    any other hovers from its settling time on; one that never settles has no
    hover window (``None``).

    Parameters
    ----------
    xy
        Horizontal positions [m], shape ``(N, 2)``.
    settling_s
        The run's settling time to the setpoint [s] (``None``: not settled).
    """
    a = np.asarray(xy, dtype=float)
    return 0.0 if not np.hypot(*a[0]) > 0 else settling_s


def rotor_limit_share(rotor_commands: ArrayLike, omega_max: float, rel_tol: float = 1e-6) -> float:
    """Share of the samples with any commanded rotor speed at a limit (0 or ``omega_max``).

    Parameters
    ----------
    rotor_commands
        Commanded rotor speeds [rad/s], shape ``(N, 4)`` (one row per sample;
        recorded every integration step, the share is the share of steps).
    omega_max
        Rotor-speed limit [rad/s].
    rel_tol
        A command within ``rel_tol · omega_max`` of a limit counts as at it (the
        allocator clips exactly; the tolerance absorbs ``sqrt(b ω²/b)`` rounding).

    Returns
    -------
    float
        Fraction in ``[0, 1]`` of the rows (``nan`` with no rows).
    """
    w = np.asarray(rotor_commands, dtype=float)
    if w.ndim != 2:
        raise ValueError(f"rotor commands must have shape (N, rotors), got {w.shape}")
    tol = rel_tol * omega_max
    at = np.any((w >= omega_max - tol) | (w <= tol), axis=1)
    return float(np.mean(at)) if at.size else math.nan
