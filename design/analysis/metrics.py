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
* **Tilt** -- the total tilt angle ``arccos(cos φ cos θ)`` in degrees.
* **Diverged** -- a non-finite sample (position or altitude), or a horizontal
  distance beyond ``DIVERGENCE_FACTOR`` (100) times the run's scale, by
  default ``‖ξ_h(0)‖`` (1 m for a run that starts at the origin).
* **Altitude lost** -- an altitude deviation beyond ``ALTITUDE_LIMIT_M`` (2 m)
  from the reference, or a non-finite altitude (``full`` runs only).
* **Failure** -- the first of "diverged", "altitude lost", "not settled" that
  applies (:func:`failure_reason`); ``simulate``, ``tune`` and the Monte Carlo
  study all read their verdicts from :func:`diverged_batch`,
  :func:`altitude_lost_batch` and :func:`failure_reason`.

All functions are pure and take numpy arrays: time ``t`` [s] of shape ``(N,)``,
horizontal positions ``xy`` [m] of shape ``(N, 2)``.  The ``*_batch`` variants
take ``(B, N, 2)`` and are vectorised, because a tuner scores hundreds of
trajectories per iteration.  Time-weighted quantities use the trapezoidal rule,
so non-uniform (adaptive-step) samples are handled correctly.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nniquad.config import ALTITUDE_LIMIT_M, BAND_FRACTION, DIVERGENCE_FACTOR, TILT_LIMIT_DEG
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
    "rms_after",
    "peak_abs",
    "diverged",
    "diverged_batch",
    "altitude_lost_batch",
    "failure_reason",
    "Metrics",
    "compute_metrics",
]

#: Settling band as a fraction of the initial distance (:data:`nniquad.config.BAND_FRACTION`).
DEFAULT_BAND_FRACTION = BAND_FRACTION
#: A run whose distance exceeds this multiple of its scale is diverged (:data:`nniquad.config.DIVERGENCE_FACTOR`).
DEFAULT_DIVERGENCE_FACTOR = DIVERGENCE_FACTOR


# ---------------------------------------------------------------------------
# input checks


def _time(t: ArrayLike) -> NDArray[np.float64]:
    ta = np.asarray(t, dtype=float)
    if ta.ndim != 1 or ta.size < 1:
        raise ValueError(f"time vector must be 1-D and non-empty, got shape {ta.shape}")
    if ta.size > 1 and np.any(np.diff(ta) < 0):
        raise ValueError("time vector must be non-decreasing")
    return ta


def _xy_batch(t: NDArray[np.float64], xy: ArrayLike, *, batched: bool) -> NDArray[np.float64]:
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
    ta = _time(t)
    a = _xy_batch(ta, xy_batch, batched=True)
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
    ta = _time(t)
    value = settling_time_batch(ta, _xy_batch(ta, xy, batched=False), band_fraction, reference_norm)[0]
    return None if math.isnan(value) else float(value)


def overshoot_pct_batch(t: ArrayLike, xy_batch: ArrayLike) -> NDArray[np.float64]:
    """Overshoot [%] of a batch of runs, shape ``(B,)`` (see :func:`overshoot_pct`).

    ``nan`` for runs with a non-finite sample or a zero initial distance.
    """
    ta = _time(t)
    a = _xy_batch(ta, xy_batch, batched=True)
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
    ta = _time(t)
    a = _xy_batch(ta, xy, batched=False)
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
    ta = _time(t)
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
    ta = _time(t)
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


def diverged_batch(
    xy_batch: ArrayLike,
    threshold_m: float | None = None,
    factor: float = DEFAULT_DIVERGENCE_FACTOR,
    *,
    scale_m: float | ArrayLike | None = None,
    z_batch: ArrayLike | None = None,
) -> NDArray[np.bool_]:
    """Divergence flags of a batch of runs (see :func:`diverged`).

    Parameters
    ----------
    xy_batch
        Horizontal positions [m], shape ``(B, N, 2)``.
    threshold_m
        Distance [m] beyond which a run has diverged; default ``factor · scale_m``.
    factor
        Multiple of the scale (default :data:`nniquad.config.DIVERGENCE_FACTOR`).
    scale_m
        Scale [m] per run, scalar or ``(B,)``; default ``‖xy[:, 0]‖`` (1 m where
        that is zero or non-finite: a run starting at the origin has no scale).
    z_batch
        Altitudes, shape ``(B, N)``; a non-finite altitude also counts as diverged.

    Returns
    -------
    ndarray of bool
        Shape ``(B,)``.
    """
    a = np.asarray(xy_batch, dtype=float)
    if a.ndim != 3 or a.shape[-1] != 2:
        raise ValueError(f"positions must have shape (B, N, 2), got {a.shape}")
    d = np.hypot(a[..., 0], a[..., 1])
    if threshold_m is not None:
        thr = np.full(d.shape[0], float(threshold_m))
    else:
        scale = d[:, 0] if scale_m is None else np.broadcast_to(np.asarray(scale_m, float), d[:, 0].shape)
        thr = factor * np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
    bad = ~np.all(np.isfinite(a), axis=(1, 2))
    if z_batch is not None:
        bad |= ~np.all(np.isfinite(np.asarray(z_batch, dtype=float).reshape(d.shape[0], -1)), axis=1)
    with np.errstate(invalid="ignore"):
        far = np.any(d > thr[:, None], axis=1)
    return bad | far


def diverged(xy: ArrayLike, threshold_m: float | None = None, factor: float = DEFAULT_DIVERGENCE_FACTOR, *,
             scale_m: float | None = None, z: ArrayLike | None = None) -> bool:
    """True when a run blew up: a non-finite sample, or a distance beyond a threshold.

    Parameters
    ----------
    xy
        Horizontal positions [m], shape ``(N, 2)``.
    threshold_m
        Distance [m] beyond which the run counts as diverged; default
        ``factor · scale_m``.
    factor
        Multiple of the scale used when ``threshold_m`` is ``None``.
    scale_m
        Scale [m]; default ``‖xy[0]‖`` (1 m when the run starts at the origin).
    z
        Altitude [m], shape ``(N,)``; non-finite counts as diverged.
    """
    a = np.asarray(xy, dtype=float)
    if a.ndim != 2 or a.shape[-1] != 2:
        raise ValueError(f"positions must have shape (N, 2), got {a.shape}")
    zb = None if z is None else np.asarray(z, dtype=float)[None]
    return bool(diverged_batch(a[None], threshold_m, factor, scale_m=scale_m, z_batch=zb)[0])


def altitude_lost_batch(z_batch: ArrayLike, limit_m: float = ALTITUDE_LIMIT_M, z_ref: float = 0.0) -> NDArray[np.bool_]:
    """Altitude-loss flags: the largest ``|z - z_ref|`` of each run exceeds ``limit_m`` (or is not finite).

    Parameters
    ----------
    z_batch
        Altitudes [m], shape ``(B, N)``.
    limit_m
        Largest allowed deviation [m] (default :data:`nniquad.config.ALTITUDE_LIMIT_M`).
    z_ref
        Reference altitude [m], same frame.

    Returns
    -------
    ndarray of bool
        Shape ``(B,)``.
    """
    z = np.asarray(z_batch, dtype=float)
    if z.ndim != 2:
        raise ValueError(f"altitudes must have shape (B, N), got {z.shape}")
    with np.errstate(invalid="ignore"):
        dev = np.max(np.abs(z - z_ref), axis=1)
        return ~(dev <= limit_m)  # NaN counts as lost


def failure_reason(diverged: bool, altitude_lost: bool | None, settled: bool) -> str | None:
    """The one verdict of a run: ``"diverged"``, ``"altitude lost"``, ``"not settled"`` or ``None`` (success).

    Checked in that order: a run that blew up has also lost its altitude and not
    settled, and is reported as diverged.
    """
    if diverged:
        return "diverged"
    if altitude_lost:
        return "altitude lost"
    if not settled:
        return "not settled"
    return None


# ---------------------------------------------------------------------------
# bundle


@dataclass(frozen=True)
class Metrics:
    """The performance numbers of one run; ``None`` where a field does not apply.

    Attributes
    ----------
    settling_s
        Settling time [s] (2 % band, last exit); ``None`` if not settled.
    overshoot_pct
        Overshoot along the initial direction [% of ‖ξ_h(0)‖].
    peak_tilt_deg
        Largest total tilt of the body [deg].
    peak_cmd_tilt_deg
        Largest commanded tilt [deg].
    tilt_limit_fraction
        Fraction of the run with the (commanded) tilt at its limit.
    peak_rotor_speed_rad_s
        Largest rotor speed [rad/s].
    altitude_dev_m
        Largest deviation of the altitude from its reference [m].
    tilt_jitter_rms_deg
        RMS tilt after settling [deg].
    diverged
        The run blew up (non-finite or far away, :func:`diverged`).
    horizon_s
        Duration of the run [s].
    altitude_lost
        The altitude deviation exceeded its limit (:func:`altitude_lost_batch`);
        ``None`` without an altitude signal.
    """

    settling_s: float | None
    overshoot_pct: float | None
    peak_tilt_deg: float | None
    peak_cmd_tilt_deg: float | None
    tilt_limit_fraction: float | None
    peak_rotor_speed_rad_s: float | None
    altitude_dev_m: float | None
    tilt_jitter_rms_deg: float | None
    diverged: bool
    horizon_s: float
    altitude_lost: bool | None = None

    @property
    def failure(self) -> str | None:
        """:func:`failure_reason` of the run: ``"diverged"``, ``"altitude lost"``, ``"not settled"`` or ``None``."""
        return failure_reason(self.diverged, self.altitude_lost, self.settling_s is not None)

    def to_json(self) -> dict[str, Any]:
        """Plain dict; ``None`` and non-finite numbers become JSON ``null``."""
        out: dict[str, Any] = {}
        for key, value in asdict(self).items():
            if isinstance(value, np.bool_):
                value = bool(value)
            elif isinstance(value, np.floating):
                value = float(value)
            if isinstance(value, float) and not math.isfinite(value):
                value = None
            out[key] = value
        return out

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> "Metrics":
        """Inverse of :meth:`to_json` (unknown keys are an error)."""
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise SimulationError(f"unknown metrics field '{unknown[0]}'")
        return cls(**{n: data.get(n) for n in names})


def _opt(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def compute_metrics(
    t: ArrayLike,
    xy: ArrayLike,
    *,
    phi: ArrayLike | None = None,
    theta: ArrayLike | None = None,
    cmd_tilt_deg: ArrayLike | None = None,
    tilt_limit_deg: float = TILT_LIMIT_DEG,
    rotor_speeds: ArrayLike | None = None,
    z: ArrayLike | None = None,
    z_ref: float = 0.0,
    band_fraction: float = DEFAULT_BAND_FRACTION,
    altitude_limit_m: float = ALTITUDE_LIMIT_M,
) -> Metrics:
    """Every metric the given signals allow, bundled in :class:`Metrics`.

    Parameters
    ----------
    t
        Sample times [s], shape ``(N,)``.
    xy
        Horizontal positions [m], shape ``(N, 2)``.
    phi, theta
        Roll and pitch [rad], shape ``(N,)``; give both for the tilt fields.
    cmd_tilt_deg
        Commanded tilt [deg], shape ``(N,)``.
    tilt_limit_deg
        Tilt limit [deg] for ``tilt_limit_fraction``; the commanded tilt is
        compared when given, else the body tilt.
    rotor_speeds
        Rotor speeds [rad/s], shape ``(N, 4)`` or ``(N,)``.
    z, z_ref
        Altitude and its reference [m] (same frame).
    band_fraction
        Settling band fraction (default 2 %).
    altitude_limit_m
        Altitude deviation counted as altitude loss [m].

    Returns
    -------
    Metrics
        Fields whose signals were not given are ``None``; for a diverged run
        settling and overshoot are ``None``.
    """
    ta = _time(t)
    a = np.asarray(xy, dtype=float)
    _xy_batch(ta, a, batched=False)
    div = diverged(a, z=z)
    settling = None if div else settling_time(ta, a, band_fraction)
    over = None if div else _opt(overshoot_pct(ta, a))
    tilt = None
    if phi is not None and theta is not None:
        tilt = tilt_deg(phi, theta)
        if tilt.shape != ta.shape:
            raise ValueError(f"roll/pitch have shape {tilt.shape} but the time vector has {ta.shape}")
    cmd = None if cmd_tilt_deg is None else np.asarray(cmd_tilt_deg, dtype=float)
    limited = cmd if cmd is not None else tilt
    return Metrics(
        settling_s=settling,
        overshoot_pct=over,
        peak_tilt_deg=None if tilt is None else _opt(float(np.max(tilt))),
        peak_cmd_tilt_deg=None if cmd is None else _opt(peak_abs(cmd)),
        tilt_limit_fraction=None if limited is None else time_on_limit_fraction(ta, limited, tilt_limit_deg),
        peak_rotor_speed_rad_s=None if rotor_speeds is None else _opt(peak_abs(rotor_speeds)),
        altitude_dev_m=None if z is None else _opt(peak_abs(np.asarray(z, float) - z_ref)),
        tilt_jitter_rms_deg=None if tilt is None else rms_after(ta, tilt, settling),
        diverged=div,
        horizon_s=float(ta[-1] - ta[0]),
        altitude_lost=None if z is None else bool(altitude_lost_batch(np.asarray(z, float)[None], altitude_limit_m,
                                                                      z_ref)[0]),
    )
