"""Statistics of a Monte Carlo study: success rate with its Wilson interval, quantiles with order-statistic intervals."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from nniquad.errors import MonteCarloError
from nniquad.study.runs import ScenarioResult

__all__ = ["Summary", "summarize", "wilson_interval", "quantile_ci", "pareto_front"]


def wilson_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``k/n``."""
    if n <= 0:
        return (0.0, 1.0)
    from scipy.stats import norm

    z = float(norm.ppf(0.5 + confidence / 2))
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z / den * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (max(0.0, centre - half), min(1.0, centre + half))


def pareto_front(cost: Sequence[float], benefit: Sequence[float]) -> list[int]:
    """Indices of the non-dominated points of a trade-off, ordered by ``cost``.

    Point ``i`` is dominated when another point has ``cost <= cost_i`` and
    ``benefit >= benefit_i`` with at least one strict (e.g. cost = nominal
    settling time, benefit = Monte Carlo success rate).  Non-finite costs are
    never on the front.

    Parameters
    ----------
    cost
        To be small (a ``None`` or ``nan`` cost: not on the front).
    benefit
        To be large.

    Returns
    -------
    list of int
        The front, by increasing cost (ties in cost: the larger benefit only).
    """
    c = np.array([math.inf if v is None else float(v) for v in cost])
    b = np.asarray(benefit, dtype=float)
    if c.shape != b.shape:
        raise ValueError("cost and benefit must have the same length")
    c = np.where(np.isfinite(c), c, math.inf)
    front: list[int] = []
    best = -math.inf
    for i in sorted(range(len(c)), key=lambda k: (c[k], -b[k])):
        if math.isfinite(c[i]) and b[i] > best:
            front.append(i)
            best = b[i]
    return front


def quantile_ci(values: Sequence[float], q: float, confidence: float = 0.95) -> tuple[float, float, float]:
    """Quantile ``q`` and its distribution-free confidence interval from order statistics.

    The estimate is the order statistic ``x_(⌈q n⌉)``.  The interval is
    ``[x_(l), x_(u)]`` with ``l = F⁻¹(α/2)``, ``u = F⁻¹(1 − α/2) + 1`` for ``F``
    the Binomial(n, q) distribution function: it covers the true quantile with
    probability at least ``confidence`` for any continuous distribution.  An
    index outside ``1..n`` gives ``-inf`` / ``+inf`` (too few samples to bound
    that side).  Values may be ``+inf`` (failures counted as "never").
    """
    from scipy.stats import binom

    x = np.sort(np.asarray(values, float))
    n = x.size
    if n == 0:
        return (float("nan"),) * 3
    alpha = 1 - confidence
    k = min(n, max(1, math.ceil(q * n - 1e-9)))
    lo_i = int(binom.ppf(alpha / 2, n, q))
    hi_i = int(binom.ppf(1 - alpha / 2, n, q)) + 1
    lo = x[lo_i - 1] if lo_i >= 1 else -math.inf
    hi = x[hi_i - 1] if hi_i <= n else math.inf
    return (float(x[k - 1]), float(lo), float(hi))


def _num(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


_FAILURE_RANK = {"diverged": 0, "altitude lost": 1, "not settled": 2}
#: The per-scenario figures summarised as p50 / p95 / max: table label, unit, scale of the shown number.
_BUDGET_FIGURES = {"steady_offset_m": ("steady offset", "m", 1.0),
                   "tilt_command_rms_deg": ("cmd tilt RMS (hover)", "deg", 1.0),
                   "rotor_limit_share": ("rotor at limit", "%", 100.0)}


def _spread(values: Sequence[float | None]) -> dict[str, float]:
    """``{"p50", "p95", "max"}`` of the reported values (empty when none is)."""
    v = np.array([x for x in values if x is not None and math.isfinite(x)], float)
    if v.size == 0:
        return {}
    return {"p50": float(np.quantile(v, 0.5)), "p95": float(np.quantile(v, 0.95)), "max": float(v.max())}


@dataclass
class Summary:
    """Statistics of a study (:func:`summarize`).

    Attributes
    ----------
    n, n_success
        Scenarios and successes.
    success_rate, success_ci
        ``n_success / n`` and its Wilson 95 % interval.
    failures
        Count per failure reason.
    settling
        ``{"p50": (value, lo, hi), "p95": ..., "p99": ...}`` [s]; failures count
        as ``+inf`` (never settled), so a quantile is ``inf`` when more than
        ``1 - q`` of the runs failed.
    peak_tilt
        Same quantiles of the peak tilt [deg], plus ``mean`` and ``max``.
    worst
        Up to ``n_worst`` results: failures first (diverged, altitude lost, not
        settled), then the longest settling times (the largest tracking RMS when following a reference).
    partial
        Computed from an interrupted study.
    tracking
        A study that follows a reference: quantiles of the RMS tracking error [m] (failures count as ``+inf``);
        :attr:`settling` is then empty.  Empty for a study without a reference.
    settling_about_wind_equilibrium
        The quantiles of :attr:`settling` measured about each scenario's wind
        equilibrium instead of the setpoint (the goalpost moved by the wind; a
        run that was lost or never settled there counts as ``+inf``); it
        decides nothing.
    noise_budget
        ``{"steady_offset_m": {...}, "tilt_command_rms_deg": {...}, "rotor_limit_share": {...}}``, each with
        ``p50``, ``p95`` and ``max`` over the scenarios that report the figure.
    """

    n: int
    n_success: int
    success_rate: float
    success_ci: tuple[float, float]
    failures: dict[str, int]
    settling: dict[str, tuple[float, float, float]]
    peak_tilt: dict[str, Any]
    max_offset_m: float
    max_altitude_dev_m: float
    worst: list[ScenarioResult]
    partial: bool = False
    tracking: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    settling_about_wind_equilibrium: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    noise_budget: dict[str, dict[str, float]] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        def q(t: tuple[float, float, float]) -> dict[str, Any]:
            return {"value": _num(t[0]), "ci95": [_num(t[1]), _num(t[2])]}

        return {
            "partial": self.partial,
            "n": self.n,
            "n_success": self.n_success,
            "success_rate": self.success_rate,
            "success_rate_ci95": list(self.success_ci),
            "failures": dict(self.failures),
            "settling_s": {k: q(v) for k, v in self.settling.items()},
            "settling_note": "failures count as never settled (+inf, written null); "
                             "a null CI bound means too few samples to bound that side",
            "peak_tilt_deg": {
                **{k: q(v) for k, v in self.peak_tilt.items() if k.startswith("p")},
                "mean": _num(self.peak_tilt["mean"]),
                "max": _num(self.peak_tilt["max"]),
                "max_index": self.peak_tilt["max_index"],
            },
            **({"tracking_rms_m": {k: q(v) for k, v in self.tracking.items()},
                "tracking_note": "RMS tracking error over each run; failures count as +inf (written null)"}
               if self.tracking else {}),
            **({"settling_time_about_wind_equilibrium_s":
                {k: q(v) for k, v in self.settling_about_wind_equilibrium.items()}}
               if self.settling_about_wind_equilibrium else {}),
            **{name: {k: _num(v) for k, v in figs.items()} for name, figs in self.noise_budget.items()},
            "max_wind_offset_m": _num(self.max_offset_m),
            "max_altitude_dev_m": _num(self.max_altitude_dev_m),
            "worst_cases": [r.to_json() for r in self.worst],
        }

    def table(self, rerun_hint: str | None = None) -> str:
        """Text table with units and 95 % confidence intervals (ASCII)."""
        def s(v: float, unit: str, d: int = 3) -> str:
            if math.isnan(v):
                return "-"
            if math.isinf(v):
                return "inf" if v > 0 else "-inf"
            return f"{v:.{d}g} {unit}"

        def ci(t: tuple[float, float, float], unit: str, never: bool = False) -> str:
            value = "never" if (never and math.isinf(t[0])) else s(t[0], unit)
            return f"{value:>12}   [{s(t[1], unit)}, {s(t[2], unit)}]"

        lines = [f"{'scenarios':<24} {self.n:>12}" + ("   (PARTIAL: interrupted)" if self.partial else "")]
        lo, hi = self.success_ci
        lines.append(f"{'success rate':<24} {100 * self.success_rate:>10.2f} %   "
                     f"[{100 * lo:.2f} %, {100 * hi:.2f} %]  ({self.n_success}/{self.n})")
        if self.failures:
            lines.append(f"{'failures':<24} " + ", ".join(f"{k}: {v}" for k, v in sorted(self.failures.items())))
        lines.append(f"{'':<24} {'value':>12}   95 % CI (inf: too few samples to bound)")
        for k, v in self.settling.items():
            lines.append(f"{'settling time ' + k:<24} {ci(v, 's', never=True)}")
        for k, v in self.tracking.items():
            lines.append(f"{'tracking RMS ' + k:<24} {ci(v, 'm')}")
        for k in ("p50", "p95", "p99"):
            lines.append(f"{'peak tilt ' + k:<24} {ci(self.peak_tilt[k], 'deg')}")
        lines.append(f"{'peak tilt max':<24} {s(self.peak_tilt['max'], 'deg'):>12}   "
                     f"(scenario {self.peak_tilt['max_index']})")
        for k, v in self.settling_about_wind_equilibrium.items():
            lines.append(f"{'wind-eq. settling ' + k:<24} {ci(v, 's', never=True)}  (about the wind equilibrium: "
                         "not the verdict)")
        for name, (label, unit, scale) in _BUDGET_FIGURES.items():
            figs = self.noise_budget.get(name)
            if figs:
                lines.append(f"{label:<24} " + ", ".join(f"{k} {s(scale * v, unit)}" for k, v in figs.items()))
        lines.append(f"{'max wind offset':<24} {s(self.max_offset_m, 'm'):>12}")
        lines.append(f"{'max altitude deviation':<24} {s(self.max_altitude_dev_m, 'm'):>12}")
        if self.worst:
            then = "the largest tracking RMS" if self.tracking else "the longest settling"
            lines.append(f"worst cases (failures first, then {then}):")
            lines.append(f"  {'index':>6} {'outcome':<14} {'settle[s]':>9} {'tilt[deg]':>9} {'mass[kg]':>8} "
                         f"{'att':>5} {'tau[ms]':>7} {'noise[cm]':>9} {'wind[N]':>7} {'r0[m]':>6}")
            for r in self.worst:
                d = r.scenario
                nan = float("nan")
                lines.append(
                    f"  {r.index:>6} {(r.failure or 'ok')[:14]:<14} "
                    f"{'-' if r.settling_s is None else f'{r.settling_s:.2f}':>9} "
                    f"{'-' if r.peak_tilt_deg is None else f'{r.peak_tilt_deg:.1f}':>9} "
                    f"{d.get('mass_kg', nan):>8.3f} {d.get('attitude_gain', nan):>5.2f} "
                    f"{1e3 * d.get('tau_motor_s', nan):>7.1f} {100 * d.get('noise_sigma_m', nan):>9.2f} "
                    f"{d.get('wind_magnitude_N', nan):>7.3f} {d.get('displacement_m', nan):>6.2f}")
            if rerun_hint:
                lines.append(f"rerun one alone: {rerun_hint}")
        return "\n".join(lines)


def summarize(results: Sequence[ScenarioResult], *, n_worst: int = 10, partial: bool = False) -> Summary:
    """Success rate (Wilson CI), settling and peak-tilt quantiles (order-statistic CIs), worst cases.

    Results are sorted by index first, so the order they arrive in does not matter.
    """
    rs = sorted(results, key=lambda r: r.index)
    n = len(rs)
    if n == 0:
        raise MonteCarloError("no finished scenarios to summarise")
    k = sum(r.success for r in rs)
    failures: dict[str, int] = {}
    for r in rs:
        if r.failure:
            key = "error" if r.failure.startswith("error") else r.failure
            failures[key] = failures.get(key, 0) + 1
    settle = np.array([r.settling_s if (r.success and r.settling_s is not None) else math.inf for r in rs])
    following = any(r.tracking_rms_m is not None for r in rs)
    rms = np.array([r.tracking_rms_m if (r.success and r.tracking_rms_m is not None) else math.inf for r in rs])
    tilts = np.array([math.inf if r.peak_tilt_deg is None else r.peak_tilt_deg for r in rs])
    finite_t = tilts[np.isfinite(tilts)]
    peak = {f"p{int(100 * q)}": quantile_ci(tilts, q) for q in (0.5, 0.95, 0.99)}
    imax = int(np.argmax(tilts))
    peak.update(mean=float(np.mean(finite_t)) if finite_t.size else math.nan, max=float(tilts[imax]),
                max_index=rs[imax].index)

    def badness(r: ScenarioResult) -> tuple:
        if r.failure:
            return (0, _FAILURE_RANK.get(r.failure, -1), r.index)
        return (1, -((r.tracking_rms_m if following else r.settling_s) or 0.0), r.index)

    worst = sorted(rs, key=badness)[: max(0, n_worst)]
    alts = [r.max_altitude_dev_m for r in rs if r.max_altitude_dev_m is not None]
    settle_eq = np.array([math.inf if r.settling_time_about_wind_equilibrium_s is None
                          else r.settling_time_about_wind_equilibrium_s for r in rs])
    budget = {name: _spread([getattr(r, name) for r in rs]) for name in _BUDGET_FIGURES}
    return Summary(
        n=n, n_success=k, success_rate=k / n, success_ci=wilson_interval(k, n), failures=failures,
        settling={} if following else {f"p{int(100 * q)}": quantile_ci(settle, q) for q in (0.5, 0.95, 0.99)},
        tracking={f"p{int(100 * q)}": quantile_ci(rms, q) for q in (0.5, 0.95, 0.99)} if following else {},
        peak_tilt=peak, max_offset_m=max(r.offset_m for r in rs),
        max_altitude_dev_m=max(alts) if alts else math.nan, worst=worst, partial=partial,
        settling_about_wind_equilibrium={} if following else {
            f"p{int(100 * q)}": quantile_ci(settle_eq, q) for q in (0.5, 0.95, 0.99)},
        noise_budget={k: v for k, v in budget.items() if v},
    )
