"""Run verdicts and the metrics bundle: one definition of a lost vehicle, of its cause and of success.

A run is **lost** -- its ``diverged`` flag, wherever it is reported
(``simulate``, certificates, the report, :class:`Metrics`) -- when it blew up
*or* lost its altitude (:func:`diverged_batch`):

* **blew up** (:func:`blew_up_batch`): a non-finite sample (position or
  altitude), or a horizontal distance beyond ``DIVERGENCE_FACTOR`` times the
  run's scale;
* **altitude lost** (:func:`altitude_lost_batch`): an altitude deviation beyond
  :data:`nniquad.config.ALTITUDE_LIMIT_M` (``full`` runs only).

The failure verdict (:func:`failure_reason`) names the cause: ``"diverged"``
(it blew up), ``"altitude lost"`` (lost through its altitude only), ``"not
settled"``, or ``None`` (success); a lost run never counts as settled.  These
functions serve :func:`nniquad.simulate`, :func:`nniquad.tune` and
:func:`nniquad.montecarlo` alike.  :func:`compute_metrics` bundles every
signal metric of :mod:`nniquad.sim.metrics` with these verdicts into a
:class:`Metrics`.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, asdict, dataclass, fields
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nniquad.config import ALTITUDE_LIMIT_M, TILT_LIMIT_DEG, XI0_M
from nniquad.errors import SimulationError
from nniquad.sim.metrics import (
    DEFAULT_BAND_FRACTION,
    DEFAULT_DIVERGENCE_FACTOR,
    overshoot_pct,
    peak_abs,
    points_batch,
    hover_window_start_s,
    rms_after,
    rotor_limit_share,
    settling_time,
    steady_offset_m,
    tilt_deg,
    time_axis,
    time_on_limit_fraction,
)

__all__ = ["diverged", "diverged_batch", "blew_up_batch", "altitude_lost_batch", "failure_reason", "Metrics",
           "compute_metrics"]


def blew_up_batch(
    xy_batch: ArrayLike,
    threshold_m: float | None = None,
    factor: float = DEFAULT_DIVERGENCE_FACTOR,
    *,
    scale_m: float | ArrayLike | None = None,
    z_batch: ArrayLike | None = None,
) -> NDArray[np.bool_]:
    """Blow-up flags of a batch of runs: a non-finite sample, or a distance beyond a threshold.

    Parameters
    ----------
    xy_batch
        Horizontal positions [m], shape ``(B, N, 2)``.
    threshold_m
        Distance [m] beyond which a run has blown up; default ``factor · scale_m``.
    factor
        Multiple of the scale (default :data:`nniquad.config.DIVERGENCE_FACTOR`).
    scale_m
        Scale [m] per run, scalar or ``(B,)``; default ``‖xy[:, 0]‖`` (1 m where
        that is zero or non-finite: a run starting at the origin has no scale).
    z_batch
        Altitudes, shape ``(B, N)``; a non-finite altitude also counts.

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


def diverged_batch(
    xy_batch: ArrayLike,
    threshold_m: float | None = None,
    factor: float = DEFAULT_DIVERGENCE_FACTOR,
    *,
    scale_m: float | ArrayLike | None = None,
    z_batch: ArrayLike | None = None,
    altitude_limit_m: float = ALTITUDE_LIMIT_M,
    z_ref: float = 0.0,
) -> NDArray[np.bool_]:
    """Lost-vehicle flags of a batch of runs: it blew up (:func:`blew_up_batch`) or lost its altitude.

    Parameters
    ----------
    xy_batch, threshold_m, factor, scale_m
        As in :func:`blew_up_batch`.
    z_batch
        Altitudes [m], shape ``(B, N)``; with them an altitude deviation beyond
        ``altitude_limit_m`` (:func:`altitude_lost_batch`) or a non-finite
        altitude also makes the run lost.
    altitude_limit_m, z_ref
        Largest allowed altitude deviation [m] and its reference (same frame as ``z_batch``).

    Returns
    -------
    ndarray of bool
        Shape ``(B,)``.
    """
    lost = blew_up_batch(xy_batch, threshold_m, factor, scale_m=scale_m, z_batch=z_batch)
    if z_batch is not None:
        lost |= altitude_lost_batch(np.asarray(z_batch, dtype=float).reshape(lost.shape[0], -1), altitude_limit_m,
                                    z_ref)
    return lost


def diverged(xy: ArrayLike, threshold_m: float | None = None, factor: float = DEFAULT_DIVERGENCE_FACTOR, *,
             scale_m: float | None = None, z: ArrayLike | None = None, altitude_limit_m: float = ALTITUDE_LIMIT_M,
             z_ref: float = 0.0) -> bool:
    """True when the vehicle of one run is lost (:func:`diverged_batch`): it blew up or lost its altitude.

    Parameters
    ----------
    xy
        Horizontal positions [m], shape ``(N, 2)``.
    threshold_m
        Distance [m] beyond which the run blew up; default ``factor · scale_m``.
    factor
        Multiple of the scale used when ``threshold_m`` is ``None``.
    scale_m
        Scale [m]; default ``‖xy[0]‖`` (1 m when the run starts at the origin).
    z
        Altitude [m], shape ``(N,)``; non-finite, or beyond ``altitude_limit_m``
        from ``z_ref``, counts as lost.
    altitude_limit_m, z_ref
        Largest allowed altitude deviation [m] and its reference.
    """
    a = np.asarray(xy, dtype=float)
    if a.ndim != 2 or a.shape[-1] != 2:
        raise ValueError(f"positions must have shape (N, 2), got {a.shape}")
    zb = None if z is None else np.asarray(z, dtype=float)[None]
    return bool(diverged_batch(a[None], threshold_m, factor, scale_m=scale_m, z_batch=zb,
                               altitude_limit_m=altitude_limit_m, z_ref=z_ref)[0])


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


def failure_reason(blew_up: bool, altitude_lost: bool | None, settled: bool) -> str | None:
    """The one verdict of a run: ``"diverged"``, ``"altitude lost"``, ``"not settled"`` or ``None`` (success).

    Checked in that order: a run that blew up (:func:`blew_up_batch`) has also
    lost its altitude and not settled, and is reported as diverged; a run lost
    through its altitude only is reported as such.  Either is a lost vehicle
    (its ``diverged`` flag, :func:`diverged_batch`).
    """
    if blew_up:
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
        Settling time [s] (2 % band of ‖ξ_h(0)‖ around the setpoint, last exit; a hover run, started at the
        setpoint, in the band of the nominal start :data:`nniquad.config.XI0_M`); ``None`` if not settled.
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
        The vehicle is lost (:func:`diverged`): it blew up (non-finite or far
        away) or lost its altitude.
    horizon_s
        Duration of the run [s].
    altitude_lost
        The altitude deviation exceeded its limit (:func:`altitude_lost_batch`);
        ``None`` without an altitude signal.
    blew_up
        The run blew up (:func:`blew_up_batch`), the cause :attr:`failure`
        calls "diverged"; ``None`` when not recorded, and then ``diverged``
        stands for it.
    follows_reference
        The run follows a reference (:mod:`nniquad.sim.tracking`): settling and overshoot, which measure the
        regulation to the origin, do not apply (``None``) and "not settled" is no failure; its tracking metrics
        judge it.
    steady_offset_m
        Mean distance from the setpoint over the last second [m]
        (:func:`nniquad.sim.metrics.steady_offset_m`); ``None`` for a lost run or one following a reference.
    tilt_command_rms_deg
        RMS of the commanded tilt over the hover window [deg]
        (:func:`nniquad.sim.metrics.hover_window_start_s`); ``None`` without a hover window.
    rotor_limit_share
        Share of the recorded samples with any commanded rotor speed at 0 or ``ω_max``
        (:func:`nniquad.sim.metrics.rotor_limit_share`; every integration step when the output period is the
        step); ``None`` without rotor commands (linear and reduced models).
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
    blew_up: bool | None = None
    follows_reference: bool = False
    steady_offset_m: float | None = None
    tilt_command_rms_deg: float | None = None
    rotor_limit_share: float | None = None

    @property
    def failure(self) -> str | None:
        """:func:`failure_reason` of the run: ``"diverged"``, ``"altitude lost"``, ``"not settled"`` or ``None``."""
        blew_up = self.diverged if self.blew_up is None else self.blew_up
        settled = bool(self.follows_reference) or self.settling_s is not None
        return failure_reason(blew_up, self.altitude_lost, settled and not self.diverged)

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
        if not self.follows_reference:
            del out["follows_reference"]  # a regulation run's record stays what it was before the field existed
        return out

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> "Metrics":
        """Inverse of :meth:`to_json` (unknown keys are an error)."""
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise SimulationError(f"unknown metrics field '{unknown[0]}'")
        # a field missing from an older record takes its default (None for the fields without one)
        return cls(**{f.name: data.get(f.name, None if f.default is MISSING else f.default) for f in fields(cls)})


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
    follows_reference: bool = False,
    rotor_commands: ArrayLike | None = None,
    omega_max: float | None = None,
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
    follows_reference
        The run follows a reference: no settling or overshoot (:attr:`Metrics.follows_reference`).
    rotor_commands, omega_max
        Commanded rotor speeds [rad/s], shape ``(N, 4)``, and their limit [rad/s], for ``rotor_limit_share``.

    Returns
    -------
    Metrics
        Fields whose signals were not given are ``None``; for a lost run
        (``diverged``: blown up or altitude lost) settling and overshoot are ``None``.
    """
    ta = time_axis(t)
    a = np.asarray(xy, dtype=float)
    points_batch(ta, a, batched=False)
    div = diverged(a, z=z, altitude_limit_m=altitude_limit_m, z_ref=z_ref)
    # a hover run (started at the setpoint) has no initial distance to scale its band, nor a direction to
    # overshoot along: it is judged in the band of the nominal start, as the Monte Carlo study and the tuner judge
    hover_start = not np.hypot(*a[0]) > 0
    norm = math.hypot(*XI0_M) if hover_start else None
    settling = None if div or follows_reference else settling_time(ta, a, band_fraction, norm)
    over = None if div or follows_reference or hover_start else _opt(overshoot_pct(ta, a))
    tilt = None
    if phi is not None and theta is not None:
        tilt = tilt_deg(phi, theta)
        if tilt.shape != ta.shape:
            raise ValueError(f"roll/pitch have shape {tilt.shape} but the time vector has {ta.shape}")
    cmd = None if cmd_tilt_deg is None else np.asarray(cmd_tilt_deg, dtype=float)
    limited = cmd if cmd is not None else tilt
    hover_from = hover_window_start_s(a, settling) if not div else None
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
        blew_up=bool(blew_up_batch(a[None], z_batch=None if z is None else np.asarray(z, float)[None])[0]),
        follows_reference=follows_reference,
        steady_offset_m=None if div or follows_reference else _opt(steady_offset_m(ta, a)),
        tilt_command_rms_deg=None if cmd is None else rms_after(ta, cmd, hover_from),
        rotor_limit_share=None if rotor_commands is None or omega_max is None else rotor_limit_share(
            rotor_commands, omega_max),
    )
