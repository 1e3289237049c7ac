"""Fast classical margins of the linearised cascade, cheap enough for every tuner candidate.

:func:`nniquad.analysis.margins.cascade_margins` costs about a second per design
(python-control FRDs on 3000 frequencies, the exact ZOH loop, disk margins).  The
tuner needs the gain interval and the phase margin at the two break points of
every candidate, so this module computes them from the same
:class:`nniquad.analysis.linearised_cascade.ClosedLoop` (Padé model of the sampling delays)
another way:

* the exact frequency response ``L(jω) = -c (jωI - A_0)⁻¹ b`` by batched solves (the
  eigenvalues of ``A_0`` set the frequency range);
* a log-spaced grid of :data:`N_FREQUENCIES` frequencies spanning the poles; every
  sign change of ``|L| - 1`` (gain crossover) and of ``Im L`` with ``Re L < 0``
  (phase crossover) is refined by Brent's method on the exact response;
* the phase margin is the smallest ``180° - |∠(-L)|`` over the gain crossovers,
  the gain interval ``(k_lo, k_hi)`` the phase-crossover gains ``-1/L`` nearest to 1
  on either side that the closed-loop eigenvalues of ``A_0 + k b c`` confirm as
  stability boundaries (as :func:`nniquad.analysis.margins.gain_interval` does);
* nominal stability by the eigenvalues of the closed loop ``A = A_0 + b c``.

The tests compare every number with ``cascade_margins`` / python-control
``stability_margins`` on several designs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from nniquad.analysis.interpolation import bracketed_root
from nniquad.analysis.linearised_cascade import BREAK_POINTS, ClosedLoop, LinearCascade, linearise_cascade
from nniquad.config import CONTROL_RATE_HZ, REQUIRED_GM_DB, REQUIRED_PM_DEG

__all__ = ["N_FREQUENCIES", "FastMargins", "fast_loop_margins", "fast_cascade_margins", "design_margins",
           "margin_shortfall"]

#: Log-spaced frequencies of the crossover search (refined by Brent's method afterwards).
N_FREQUENCIES = 400


@dataclass(frozen=True)
class FastMargins:
    """Margins at one break point (the fields of :class:`nniquad.analysis.margins.Margins` the tuner needs).

    Attributes
    ----------
    break_point
        ``"horizontal"`` or ``"attitude"``.
    rate_hz
        Position sample rate of the Padé delay model [Hz] (``None``: continuous).
    stable
        Closed loop stable at unit gain.
    gm_db, gm_lower_db
        Gain increase / reduction that destabilise the loop [dB] (``inf`` / ``-inf`` if none;
        ``nan`` if unstable).
    pm_deg
        Smallest phase margin over the gain crossovers [deg] (``inf`` if none).
    w_gc_rad_s, w_pc_rad_s
        Gain crossover of the phase margin, phase crossover of the nearer gain-interval end [rad/s].
    """

    break_point: str
    rate_hz: float | None
    stable: bool
    gm_db: float
    gm_lower_db: float
    pm_deg: float
    w_gc_rad_s: float
    w_pc_rad_s: float

    @property
    def meets_requirement(self) -> bool:
        """GM >= ``REQUIRED_GM_DB`` both ways and PM >= ``REQUIRED_PM_DEG`` on a stable loop."""
        return bool(self.stable and self.gm_db >= REQUIRED_GM_DB and self.gm_lower_db <= -REQUIRED_GM_DB
                    and self.pm_deg >= REQUIRED_PM_DEG)

    def shortfall(self, include_pm: bool = True) -> float:
        """How far the requirement is missed, in requirement units (0 if met; ``inf`` if unstable).

        ``max(0, 1 - PM/45°) + max(0, 1 - GM/6 dB) + max(0, 1 - |GM_lower|/6 dB)``: a ranked
        penalty for the tuner (without the PM term when ``include_pm`` is false).

        Parameters
        ----------
        include_pm
            Count the phase-margin term.
        """
        if not self.stable:
            return math.inf
        pm = max(0.0, 1.0 - self.pm_deg / REQUIRED_PM_DEG) if include_pm else 0.0
        return pm + max(0.0, 1.0 - self.gm_db / REQUIRED_GM_DB) + max(0.0, 1.0 + self.gm_lower_db / REQUIRED_GM_DB)

    def to_json(self) -> dict[str, Any]:
        """Plain dictionary; non-finite numbers as strings (``"inf"``, ``"-inf"``, ``"nan"``)."""
        d: dict[str, Any] = {
            "break_point": self.break_point, "rate_hz": self.rate_hz, "stable": self.stable,
            "gm_db": self.gm_db, "gm_lower_db": self.gm_lower_db, "pm_deg": self.pm_deg,
            "w_gc_rad_s": self.w_gc_rad_s, "w_pc_rad_s": self.w_pc_rad_s,
        }
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = str(v)
        d["meets_requirement"] = self.meets_requirement
        return d


#: Relative step beyond a phase-crossover gain at which the eigenvalues must confirm instability.
_CONFIRM = 1e-5


def _db(k: float) -> float:
    if k == 0.0:
        return -math.inf
    return 20.0 * math.log10(k) if math.isfinite(k) else math.inf


def _stable(A: np.ndarray) -> bool:
    return bool(np.max(np.linalg.eigvals(A).real) < 0.0)


class _Modal:
    """``L(jω) = -c (jω I - A_0)⁻¹ b`` by batched linear solves (one LU per frequency, n ~ 30).

    A modal sum from one eigen-decomposition would be cheaper still, but the
    horizontal loop's open loop holds the double integrator (a defective zero
    eigenvalue) and near-integrator poles with huge residues, where the modal
    form loses every digit; the eigenvalues are used only for the frequency range.
    """

    def __init__(self, A0: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
        self.A0, self.b, self.c = A0, b.astype(complex), c
        self.lam = np.linalg.eigvals(A0)
        self.eye = np.eye(A0.shape[0])

    def __call__(self, w: np.ndarray) -> np.ndarray:
        s = 1j * np.atleast_1d(np.asarray(w, float))
        n = self.A0.shape[0]
        M = s[:, None, None] * np.eye(n)[None] - self.A0[None]
        x = np.linalg.solve(M, np.broadcast_to(self.b[:, None], (len(s), n, 1)))[..., 0]
        return -(x @ self.c)

    def exact(self, w: float) -> complex:
        """``L(jω)`` at one frequency."""
        return complex(-(self.c @ np.linalg.solve(1j * w * self.eye - self.A0, self.b)))


def _bisect(f, a: float, b: float, fa: float) -> float:
    """Root of a scalar function with a sign change on [a, b] (Brent's method in log frequency)."""

    return math.exp(bracketed_root(lambda u: f(math.exp(u)), math.log(a), math.log(b), xtol=1e-12, rtol=1e-12))


def fast_loop_margins(cl: ClosedLoop, break_point: str, rate_hz: float | None = None,
                      n_frequencies: int = N_FREQUENCIES) -> FastMargins:
    """Margins at one break point of a closed loop (module docstring).

    Parameters
    ----------
    cl
        The closed loop (:meth:`nniquad.analysis.linearised_cascade.LinearCascade.closed_loop`).
    break_point
        One of ``cl.breaks``.
    rate_hz
        Label of the Padé sampling model used to build ``cl``.
    n_frequencies
        Grid size of the crossover search.

    Returns
    -------
    FastMargins
    """
    b, c = cl.breaks[break_point]
    A0 = cl.A - np.outer(b, c)
    nan = math.nan
    if not _stable(cl.A):
        return FastMargins(break_point, rate_hz, False, nan, nan, nan, nan, nan)
    L = _Modal(A0, b, c)
    mag = np.abs(L.lam)
    mag = mag[mag > 0]
    lo = max(1e-2 * float(np.min(mag)), 1e-4) if mag.size else 1e-3
    hi = 1e2 * float(np.max(mag)) if mag.size else 1e3
    w = np.geomspace(lo, hi, n_frequencies)
    resp = L(w)
    # gain crossovers: |L| = 1
    g = np.abs(resp) - 1.0
    pm, w_gc = math.inf, nan
    for i in np.nonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0)[0]:
        wc = _bisect(lambda x: abs(L.exact(x)) - 1.0, w[i], w[i + 1], g[i])
        Lc = L.exact(wc)
        # phase margin: arg L + 180 deg, wrapped to (-180, 180] (python-control's convention)
        pmi = math.degrees(float(np.angle(-Lc)))
        if abs(pmi) < abs(pm):
            pm, w_gc = pmi, wc
    # phase crossovers: Im L = 0 with Re L < 0; the gain k = -1/L moves a pole onto the axis there
    im = resp.imag
    ks: list[tuple[float, float]] = []
    for i in np.nonzero(np.sign(im[:-1]) * np.sign(im[1:]) < 0)[0]:
        wp = _bisect(lambda x: L.exact(x).imag, w[i], w[i + 1], im[i])
        re = L.exact(wp).real
        if re < 0:
            ks.append((-1.0 / re, wp))
    BC = np.outer(b, c)

    def unstable(k: float) -> bool:
        return not _stable(A0 + k * BC)

    above = sorted((k, wp) for k, wp in ks if k > 1.0)
    below = sorted(((k, wp) for k, wp in ks if k < 1.0), reverse=True)
    k_hi, w_hi = next(((k, wp) for k, wp in above if unstable(k * (1 + _CONFIRM))), (math.inf, nan))
    k_lo, w_lo = next(((k, wp) for k, wp in below if unstable(k * (1 - _CONFIRM))), (0.0, nan))
    gm, gml = _db(k_hi), _db(k_lo)
    w_pc = w_hi if abs(gm) <= abs(gml) else w_lo
    return FastMargins(break_point, rate_hz, True, gm, gml, float(pm), float(w_gc), float(w_pc))


def fast_cascade_margins(cascade: LinearCascade, rate_hz: float | None = CONTROL_RATE_HZ, *,
                         variant: str = "discrete", pade_order: int = 2) -> dict[str, FastMargins]:
    """Fast margins at both break points (:data:`nniquad.analysis.linearised_cascade.BREAK_POINTS`), Padé sampling model.

    The same closed loop as :func:`nniquad.analysis.margins.cascade_margins` (its ``"horizontal"`` and
    ``"attitude"`` entries).

    Parameters
    ----------
    cascade
        The linearised cascade.
    rate_hz
        The control rate [Hz] (``None``: continuous).
    variant
        ``"discrete"`` or ``"held"`` (:data:`nniquad.analysis.linearised_cascade.CONTROLLER_VARIANTS`).
    pade_order
        Order of the Padé model of each sampling delay.
    """
    cl = cascade.closed_loop(rate_hz, variant=variant, pade_order=pade_order)
    return {bp: fast_loop_margins(cl, bp, rate_hz) for bp in BREAK_POINTS}


def design_margins(vehicle, gains, inner, *, tilt_limit_deg: float | None = None,
                   rate_hz: float | None = CONTROL_RATE_HZ) -> dict[str, FastMargins]:
    """Linearise the cascade of one design and return its fast margins (``{}`` entries unstable on failure).

    Parameters
    ----------
    vehicle, gains, inner
        The design (nominal vehicle, NNI gains, inner-loop gains).
    tilt_limit_deg
        Tilt limit [deg] (inactive at hover).
    rate_hz
        Position sample rate [Hz] (default :data:`nniquad.config.CONTROL_RATE_HZ`).
    """

    cas = linearise_cascade(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg)
    return fast_cascade_margins(cas, rate_hz)


def margin_shortfall(margins: dict[str, FastMargins], include_pm: bool = True) -> float:
    """Sum of :meth:`FastMargins.shortfall` over the break points (0 when every requirement is met).

    Parameters
    ----------
    margins
        The margins by break point.
    include_pm
        Count the phase-margin terms (``False``: the gain margins only).
    """
    return float(sum(m.shortfall(include_pm) for m in margins.values()))
