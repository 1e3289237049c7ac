"""Classical stability margins of the linearised cascade at its two break points.

Break points (:mod:`nniquad.analysis.linearised_cascade`):

``horizontal``
    the horizontal acceleration command ``a_h`` of the x axis (y loop closed);
``attitude``
    the roll-torque command (every other loop closed).

Each loop transfer function ``L`` is in the negative-feedback convention
(closed loop ``1 + L = 0``).  The gain and phase margins and their crossover
frequencies come from the exact frequency response on a dense grid, interpolated
and searched as python-control's ``stability_margins`` does for frequency-response
data (:func:`frd_crossings`, numpy and scipy: the tests compare it with
python-control, which a cold ``nniquad verify`` then need not import); the disk
margin is balanced (skew 0).  A loop can be conditionally
stable (the attitude loop encloses the horizontal loop, whose gain is large at
low frequency), so the gain margin is stated as an interval: the largest gain
reduction and the largest gain increase that keep the loop stable.  Both ends
are found from the phase crossovers and confirmed by the closed-loop
eigenvalues (continuous time) or spectral radius (discrete time).

Sampling: ``method="pade"`` uses the continuous closed loop with Padé models of
the sample-and-hold delays; ``method="zoh"`` (horizontal break point only) is
exact: the loop broken at the discrete-time command ``a_h[k]`` of the ZOH
discretisation (:mod:`nniquad.analysis.sampled`).  The attitude loop is
continuous (the breaking of a continuous signal inside a sampled loop has no
exact LTI loop transfer function), so it uses ``"pade"``; its gain interval is
also checked exactly by :func:`nniquad.analysis.sampled.sampled_gain_interval`.

Requirement (flight-control practice, e.g. MIL-F-9490D): gain margin at least
:data:`nniquad.config.REQUIRED_GM_DB` both ways and phase margin at least
:data:`nniquad.config.REQUIRED_PM_DEG`.

The disk margin measures how far the loop is from *losing* stability, so it
needs a stable closed loop at unit gain: for an unstable loop the formula still
returns a number (``2/max|(1 - L)/(1 + L)|``), but it guarantees nothing, and
:class:`Margins` reports the disk margin as not applicable (``None``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from nniquad.analysis.interpolation import InterpolatingSpline, bracketed_root
from nniquad.analysis.linearised_cascade import BREAK_POINTS, LinearCascade
from nniquad.analysis.sampled import sampled_cascade
from nniquad.config import CONTROL_RATE_HZ, REQUIRED_GM_DB, REQUIRED_PM_DEG

__all__ = [
    "Margins",
    "loop_margins",
    "gain_interval",
    "frequency_grid",
    "frequency_response",
    "frd_crossings",
    "disk_margin",
    "cascade_margins",
]


def _db(k: float) -> float:
    if k == 0.0:
        return -math.inf
    return 20.0 * math.log10(k) if math.isfinite(k) else math.inf


def _stable(A: np.ndarray, dt: float | None) -> bool:
    ev = np.linalg.eigvals(A)
    return bool(np.max(np.abs(ev)) < 1.0) if dt else bool(np.max(ev.real) < 0.0)


def gain_interval(L, k_candidates: np.ndarray | None = None) -> tuple[float, float]:
    """The interval of loop gains ``k`` around 1 for which ``1 + k L = 0`` stays stable.

    Parameters
    ----------
    L
        Loop transfer function (:class:`nniquad.analysis.loops.LinearSystem` or python-control
        ``StateSpace``; discrete if ``L.dt``).
    k_candidates
        Gains at which a closed-loop pole can cross the stability boundary
        (``-1/L`` at the phase crossovers); computed when ``None``.

    Returns
    -------
    k_lo, k_hi : float
        ``0 <= k_lo < 1 < k_hi <= inf``; ``(nan, nan)`` if the loop is unstable at ``k = 1``.
    """
    A0, B, C = np.asarray(L.A), np.asarray(L.B), np.asarray(L.C)
    dt = L.dt if L.dt not in (0, None) else None

    def closed(k: float) -> np.ndarray:
        return A0 - k * (B @ C)  # 1 + k L = 0, L = C (sI - A0)^{-1} B

    if not _stable(closed(1.0), dt):
        return math.nan, math.nan
    if k_candidates is None:
        w = frequency_grid(L)
        gm = frd_crossings(frequency_response(L, w), w)[0]
        k_candidates = np.atleast_1d(np.asarray(gm, float))
    ks = np.sort(np.unique(np.abs(k_candidates[np.isfinite(k_candidates)])))
    # a crossing at k is confirmed when the loop is unstable just beyond it
    k_hi = next((k for k in ks if k > 1.0 and not _stable(closed(k * (1 + 1e-6)), dt)), math.inf)
    k_lo = next((k for k in ks[::-1] if k < 1.0 and not _stable(closed(k * (1 - 1e-6)), dt)), 0.0)
    return float(k_lo), float(k_hi)


@dataclass(frozen=True)
class Margins:
    """Stability margins at one break point.

    Attributes
    ----------
    break_point
        ``"horizontal"`` or ``"attitude"``.
    method
        ``"continuous"`` (continuous measurement), ``"pade"`` (Padé model of the
        sampling delays) or ``"zoh"`` (exact discrete-time loop).
    rate_hz
        Sample rate of the position measurement [Hz] (``None``: continuous).
    gm_db
        Gain margin [dB]: the gain increase that destabilises the loop (``inf`` if none).
    gm_lower_db
        The gain reduction that destabilises the loop [dB, ≤ 0] (``-inf`` if none).
    pm_deg
        Phase margin [deg] (smallest over the gain crossovers; ``inf`` if none).
    w_gc_rad_s
        Gain crossover frequency of the phase margin [rad/s].
    w_pc_rad_s
        Phase crossover frequency of python-control's gain margin [rad/s].
    disk_alpha
        Balanced disk margin α (skew 0); ``None`` (not applicable) when the
        closed loop is unstable at unit gain (module docstring).
    disk_gm_db, disk_pm_deg
        Gain [dB] and phase [deg] margins guaranteed jointly by the disk
        (``None`` with :attr:`disk_alpha`).
    stable
        Whether the closed loop is stable at unit gain.
    """

    break_point: str
    method: str
    rate_hz: float | None
    gm_db: float
    gm_lower_db: float
    pm_deg: float
    w_gc_rad_s: float
    w_pc_rad_s: float
    disk_alpha: float | None
    disk_gm_db: float | None
    disk_pm_deg: float | None
    stable: bool

    @property
    def meets_requirement(self) -> bool:
        """Gain margin >= ``REQUIRED_GM_DB`` both ways and phase margin >= ``REQUIRED_PM_DEG``
        (:mod:`nniquad.config`) on a stable loop."""
        return bool(self.stable and self.gm_db >= REQUIRED_GM_DB and self.gm_lower_db <= -REQUIRED_GM_DB
                    and self.pm_deg >= REQUIRED_PM_DEG)

    def to_json(self) -> dict[str, Any]:
        """Plain dictionary with units in the keys; non-finite numbers as strings ("inf", "nan"),
        a disk margin that does not apply as ``None`` (JSON ``null``)."""
        d = asdict(self)
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = str(v)
        d["meets_requirement"] = self.meets_requirement
        d["required"] = {"gm_db": REQUIRED_GM_DB, "pm_deg": REQUIRED_PM_DEG}
        return d

    def __str__(self) -> str:
        rate = "continuous" if self.rate_hz is None else f"{self.rate_hz:g} Hz"
        verdict = "meets" if self.meets_requirement else "FAILS"
        disk = ("disk margin n/a (unstable loop)" if self.disk_alpha is None else
                f"disk alpha {self.disk_alpha:.3g} ({self.disk_gm_db:.2f} dB, {self.disk_pm_deg:.2f} deg)")
        return (f"{self.break_point:10s} ({self.method}, {rate}): GM +{self.gm_db:.2f}/{self.gm_lower_db:.2f} dB, "
                f"PM {self.pm_deg:.2f} deg at {self.w_gc_rad_s:.3g} rad/s, {disk} -- {verdict} "
                f"GM >= {REQUIRED_GM_DB:g} dB, PM >= {REQUIRED_PM_DEG:g} deg")


def frequency_grid(L, n: int = 3000) -> np.ndarray:
    """Log-spaced frequencies [rad/s]: two decades around the poles' range, capped below Nyquist if discrete."""
    dt = L.dt if L.dt not in (0, None) else None
    p = np.asarray(L.poles(), complex)
    mag = np.abs(np.log(p[np.abs(p) > 0])) / dt if dt else np.abs(p)
    mag = mag[np.isfinite(mag) & (mag > 0)]
    lo = 1e-2 * float(np.min(mag)) if mag.size else 1e-3
    hi = 1e2 * float(np.max(mag)) if mag.size else 1e3
    if dt:
        hi = min(hi, math.pi / dt * (1 - 1e-9))
    return np.geomspace(max(lo, 1e-4), hi, n)


def frequency_response(L, omega: np.ndarray) -> np.ndarray:
    """``L(jω)`` (continuous) or ``L(e^{jωT})`` (discrete) of a SISO state-space system, by batched solves."""
    A, B, C, D = (np.asarray(M, float) for M in (L.A, L.B, L.C, L.D))
    dt = L.dt if L.dt not in (0, None) else None
    s = np.exp(1j * omega * dt) if dt else 1j * omega
    n = A.shape[0]
    M = s[:, None, None] * np.eye(n)[None] - A[None]
    X = np.linalg.solve(M, np.broadcast_to(B.astype(complex), (len(omega),) + B.shape))
    return (C @ X)[:, 0, 0] + D[0, 0]


def frd_crossings(resp: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every phase and gain crossover of a sampled frequency response, with its gain or phase margin.

    The method of python-control's ``stability_margins(FRD(resp, omega, smooth=True),
    returnall=True)``, written with scipy: the response is interpolated by a
    parametric cubic spline through its real and imaginary parts (``splprep``,
    ``s = 0``, weights ``1/(|L| + 0.001)``); a sign change of ``∠(-L)`` between two
    grid frequencies with ``Re L <= 0`` at the first is a phase crossover, a sign
    change of ``|L| - 1`` a gain crossover, each refined by Brent's method (``brentq``'s tolerances) on the
    interpolated response.

    Parameters
    ----------
    resp : complex ndarray
        ``L`` at the frequencies ``omega`` (continuous ``L(jω)`` or discrete ``L(e^{jωT})``).
    omega : ndarray
        Increasing frequencies [rad/s], at least 2.

    Returns
    -------
    gm, pm, w_pc, w_gc : ndarray
        Gain margins (factors ``1/|L|``) at the phase crossovers ``w_pc`` [rad/s]
        and phase margins [deg] at the gain crossovers ``w_gc`` [rad/s], in
        increasing frequency.
    """

    w = np.asarray(omega, float)
    r = np.asarray(resp, complex)
    # splprep's interpolating spline (s = 0), without importing scipy.interpolate (nniquad.analysis.interpolation)
    interp = InterpolatingSpline(w, r)

    def phase_from_180(f: Any) -> Any:
        return np.angle(-interp(f))

    def gain_minus_one(f: Any) -> Any:
        return np.abs(interp(f)) - 1.0

    idx = np.where(np.diff(np.sign(phase_from_180(w))))[0]
    idx = idx[np.real(interp(w[idx])) <= 0] if idx.size else idx
    w_pc = np.array([bracketed_root(phase_from_180, w[i], w[i + 1]) for i in idx], dtype=float)
    idx = np.where(np.diff(np.sign(gain_minus_one(w))))[0]
    w_gc = np.array([bracketed_root(gain_minus_one, w[i], w[i + 1]) for i in idx], dtype=float)
    with np.errstate(all="ignore"):  # |L| = 0 at a phase crossover: an infinite margin
        gm = 1.0 / np.abs(interp(w_pc)) if w_pc.size else np.zeros(0)
    pm = np.remainder(np.angle(interp(w_gc), deg=True), 360.0) - 180.0 if w_gc.size else np.zeros(0)
    return gm, pm, w_pc, w_gc


def disk_margin(resp: np.ndarray) -> tuple[float, float, float]:
    """Balanced (skew 0) disk margin from a frequency response: ``α = 2/max|(1 - L)/(1 + L)|``.

    Returns
    -------
    alpha, gain_margin_factor, phase_margin_deg
        The disk ``(1 + α δ/2)/(1 - α δ/2)``, ``|δ| <= 1``, guarantees the gains
        ``[(2-α)/(2+α), (2+α)/(2-α)]`` and phases ``±2 atan(α/2)`` jointly.
    """
    alpha = 2.0 / float(np.max(np.abs((1 - resp) / (1 + resp))))
    gm = (2 + alpha) / (2 - alpha) if alpha < 2 else math.inf
    return alpha, gm, math.degrees(2 * math.atan(alpha / 2))


def loop_margins(L, break_point: str, method: str, rate_hz: float | None,
                 omega: np.ndarray | None = None) -> Margins:
    """Margins of one loop transfer function (negative-feedback convention).

    The frequency response is evaluated exactly on a dense grid and searched for
    crossovers as frequency-response data (:func:`frd_crossings`; python-control's
    ``"poly"`` method loses precision on the 20-state discrete loops).  The gain interval is confirmed
    by closed-loop eigenvalues (:func:`gain_interval`).

    Parameters
    ----------
    L
        SISO state-space system with ``A, B, C, D, dt`` and ``poles()``: a
        :class:`nniquad.analysis.loops.LinearSystem` or a python-control ``StateSpace``
        (continuous or discrete).
    break_point, method, rate_hz
        Labels stored in the result.
    omega
        Frequency grid [rad/s]; :func:`frequency_grid` by default.

    Returns
    -------
    Margins
    """
    w = frequency_grid(L) if omega is None else np.asarray(omega, float)
    resp = frequency_response(L, w)
    gm, pm, wpc, wgc = frd_crossings(resp, w)
    gm, pm, wpc, wgc = (np.atleast_1d(np.asarray(v, float)) for v in (gm, pm, wpc, wgc))
    k_lo, k_hi = gain_interval(L, gm)
    stable = math.isfinite(k_lo)
    if pm.size:
        i = int(np.argmin(np.abs(pm)))
        pm_deg, w_gc = float(pm[i]), float(wgc[i])
    else:
        pm_deg, w_gc = math.inf, math.nan
    if gm.size:  # the phase crossover whose gain margin is closest to 0 dB
        j = int(np.argmin(np.abs(np.log(gm))))
        w_pc = float(wpc[j])
    else:
        w_pc = math.nan
    # the disk margin presumes a stable nominal loop; for an unstable one it does not apply
    alpha, dgm, dpm = disk_margin(resp) if stable else (None, None, None)
    return Margins(
        break_point=break_point, method=method, rate_hz=rate_hz,
        gm_db=_db(k_hi) if stable else math.nan, gm_lower_db=_db(k_lo) if stable else math.nan,
        pm_deg=pm_deg, w_gc_rad_s=w_gc, w_pc_rad_s=w_pc,
        disk_alpha=alpha, disk_gm_db=None if dgm is None else _db(dgm), disk_pm_deg=dpm, stable=stable,
    )


def cascade_margins(cascade: LinearCascade, rate_hz: float | None = CONTROL_RATE_HZ, *, variant: str = "discrete",
                    pade_order: int = 2) -> dict[str, Margins]:
    """Margins at both break points, plus the exact discrete-time horizontal margins when sampled.

    Parameters
    ----------
    cascade
        The linearised cascade (:func:`nniquad.analysis.linearised_cascade.linearise_cascade`).
    rate_hz
        Position sample rate [Hz]; ``None`` for a continuous measurement.
    variant
        ``"discrete"`` or ``"held"`` (:data:`nniquad.analysis.linearised_cascade.CONTROLLER_VARIANTS`).
    pade_order
        Order of the Padé approximants of the sampling delays.

    Returns
    -------
    dict
        ``"horizontal"``, ``"attitude"`` (continuous or Padé) and, when sampled,
        ``"horizontal_zoh"`` (exact).
    """

    cl = cascade.closed_loop(rate_hz, variant=variant, pade_order=pade_order)
    method = "continuous" if rate_hz is None else "pade"
    out = {bp: loop_margins(cl.loop_system(bp), bp, method, rate_hz) for bp in BREAK_POINTS}
    if rate_hz is not None:
        sd = sampled_cascade(cascade, rate_hz, variant=variant)
        # the held variant has no discrete a_h[k]: its x loop is broken at the sampled measurement,
        # the same scalar loop (the controller is diagonal, so every path back to a_h_x passes xi_x)
        name = "horizontal" if variant == "discrete" else "measurement"
        out["horizontal_zoh"] = loop_margins(sd.loop_system(name), "horizontal", "zoh", rate_hz)
    return out
