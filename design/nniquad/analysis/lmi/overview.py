"""The job ``lmis``: every LMI of a vehicle and gain set, with the independent cross-checks.

Next to the LMIs (solved with Clarabel, re-checked with numpy) the report holds
the checks that do not use an LMI solver at all: the exact Routh condition
``m kp delta > 1``, the smallest sector gamma, the closed-loop poles
(python-control), the definition-level frequency-domain NI/SNI checks of plant
and controller, and whether the paper's start lies in the certified region.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from nniquad.analysis.frequency import ni_interconnection_check
from nniquad.analysis.lmi import run_all
from nniquad.analysis.lmi.reduced_region import reach_of, start_certified
from nniquad.analysis.lmi.solver import LMIResult
from nniquad.analysis.reduced_loop import PolesDamping, ReducedLoop
from nniquad.config import MASS_RANGE_FRACTION, TILT_LIMIT_DEG, XI0_M
from nniquad.errors import GainError, VehicleError
from nniquad.laws.base import GainBlock
from nniquad.laws.nni import PAPER_GAINS
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle
from nniquad.validate import finite_number

__all__ = ["LMIReport", "lmis"]

#: What the margin of each LMI family measures.
MARGIN_MEANING = {
    "ni_lemma_paper": "min eig P",
    "ni_lemma_dissipation": "min eig P",
    "ni_lemma_lanzon_petersen": "min eig Y",
    "sni_lemma": "-max eig(AY+YA')",
    "ni_dissipation_strict": "eta",
    "closed_loop_decay": "eps 1/s",
    "robust_mass_decay": "eps 1/s",
    "region_of_attraction": "r m",
}


@dataclass(frozen=True)
class LMIReport:
    """Every LMI of one loop, with the cross-checks (see :func:`lmis`).

    Attributes
    ----------
    vehicle
        The vehicle (mass and gravity of the loop).
    loop
        The reduced closed loop.
    mass_range
        True-mass interval of the robust LMIs [kg].
    tilt_limit_deg
        Tilt limit of the region-of-attraction LMI [deg].
    results
        One :class:`LMIResult` per LMI, in the order of :func:`nniquad.analysis.lmi.run_all`.
    poles
        Closed-loop poles and damping (python-control).
    frequency
        Per axis, the frequency-domain NI/SNI verdicts of plant and controller.
    """

    vehicle: Vehicle
    loop: ReducedLoop
    mass_range: tuple[float, float]
    tilt_limit_deg: float
    results: tuple[LMIResult, ...]
    poles: PolesDamping
    frequency: dict[str, dict[str, Any]]

    def __getitem__(self, name: str) -> LMIResult:
        for r in self.results:
            if r.name == name:
                return r
        raise KeyError(name)

    @property
    def feasible(self) -> dict[str, bool]:
        """LMI name -> feasible (solver answer that passed the numpy re-check)."""
        return {r.name: bool(r.feasible) for r in self.results}

    @property
    def region_of_attraction(self) -> list[LMIResult]:
        """The region-of-attraction results (one, or one per axis)."""
        return [r for r in self.results if r.name.startswith("region_of_attraction")]

    @property
    def certified_reach_m(self) -> float:
        """Largest displacement from rest the region-of-attraction LMI certifies [m]."""
        return reach_of(self.region_of_attraction)

    @property
    def start_certified(self) -> bool:
        """Whether the paper's start (:data:`nniquad.config.XI0_M`) lies in the certified region."""
        return start_certified(self.region_of_attraction, XI0_M)

    def __repr__(self) -> str:
        n_ok = sum(self.feasible.values())
        return (f"LMIReport({n_ok}/{len(self.results)} LMIs feasible, decay {self.poles.decay_rate:.4g} 1/s, "
                f"certified reach {self.certified_reach_m:.4g} m, 1/gamma = {self.loop.margin_product:.4g})")

    def table(self) -> str:
        """The text ``nniquad lmi`` prints: one row per LMI, then the cross-checks."""
        v, loop, g = self.vehicle, self.loop, self.loop.gains
        kpx, kpy = g.axes()
        lines = [f"vehicle {v.name}: m = {v.m:g} kg, g = {v.g:g} m/s^2",
                 f"gains: kp_x = {kpx:g}, kp_y = {kpy:g} 1/s^2, Gamma = {g.Gamma:g}, delta = {g.delta:g}", ""]
        header = f"{'LMI':<42} {'feasible':<8} {'status':<18} {'margin':>11}  {'(meaning)':<18} key values"
        lines += [header, "-" * len(header)]
        for r in self.results:
            base = r.name.split("[")[0]
            margin = "-" if not math.isfinite(r.margin) else f"{r.margin:.5g}"
            keys = [f"{k}={r.values[k]:.4g}" for k in
                    ("decay_rate_poles", "decay_rate_poles_pointwise_min", "m_min_exact", "max_displacement_m", "u0")
                    if k in r.values]
            for k in ("P", "Y"):
                M = r.matrices.get(k)
                if M is not None and M.shape[0] <= 2:
                    text = np.array2string(M, precision=5, suppress_small=True, separator=",").replace("\n", "")
                    keys.append(f"{k}={text}")
            if "ni_dissipation_max_eig" in r.residuals and r.feasible:
                keys.append(f"NI dissipation of this P: max eig {r.residuals['ni_dissipation_max_eig']:+.3g}")
            lines.append(f"{r.name:<42} {'yes' if r.feasible else 'NO':<8} {r.status:<18} {margin:>11}  "
                         f"{MARGIN_MEANING.get(base, ''):<18} {' '.join(keys)}")
        pd = self.poles
        slow = pd.poles[0]
        lines += ["", "cross-checks",
                  f"  Routh: 1/gamma = {loop.margin_product:.4g} (m kp delta for the NNI law; stable iff > 1); smallest sector gamma = "
                  f"{loop.smallest_gamma:.4g} (paper needs < 1)",
                  f"  poles (python-control): max Re = {pd.max_real_part:.4g} 1/s, min damping = {pd.min_damping:.4g}, "
                  f"slowest pair {slow.real:.4g} +/- {abs(slow.imag):.4g}j; -2 max Re = {pd.decay_rate:.4g} 1/s"]
        for label, f in self.frequency.items():
            res = ", ".join(f"K0({w:.4g} rad/s) = {k0:.4g}" for w, k0 in f["plant_residues"])
            lines.append(f"  frequency [{label}]: plant NI={f['plant_ni']} SNI={f['plant_sni']} ({res}); "
                         f"controller NI={f['controller_ni']} SNI={f['controller_sni']}; G(0)C(0) = "
                         f"{f['dc_loop_gain']:.4g}; NI theorem predicts stable={f['predicted_stable']}, "
                         f"poles stable={f['poles_stable']}")
        roa = self.region_of_attraction
        if roa:
            how = "norm limit, rotation-invariant ellipsoid" if len(roa) == 1 else "per-axis inscribed limit"
            start = f"({XI0_M[0]:g}, {XI0_M[1]:g}) m"
            lines.append(f"  region of attraction: displacement from rest up to {self.certified_reach_m:.4g} m "
                         f"certified ({how}, u0 = {roa[0].values.get('u0', float('nan')):.4g} m/s^2); the paper's "
                         f"start {start} is {'inside' if self.start_certified else 'NOT inside'} the certified set")
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """``vehicle, m, g, gains, mass_range, tilt_limit_deg, lmis, frequency, poles`` (units in the LMI notes)."""
        pd = self.poles
        return {
            "vehicle": self.vehicle.name,
            "m": self.vehicle.m,
            "g": self.vehicle.g,
            "gains": self.loop.gains.as_dict(),
            "mass_range": list(self.mass_range),
            "tilt_limit_deg": self.tilt_limit_deg,
            "lmis": [r.to_json() for r in self.results],
            "frequency": self.frequency,
            "poles": {"real": pd.poles.real.tolist(), "imag": pd.poles.imag.tolist(), "min_damping": pd.min_damping},
        }


def _frequency(loop: ReducedLoop) -> dict[str, dict[str, Any]]:

    out: dict[str, dict[str, Any]] = {}
    for label, _ in loop.axes:
        ic = ni_interconnection_check(loop.plant_system(label), loop.controller_system())
        out[label] = {
            "plant_ni": ic.plant.is_ni, "plant_sni": ic.plant.is_sni,
            "plant_residues": [[w, float(K.real.ravel()[0])] for w, K in ic.plant.residues],
            "controller_ni": ic.controller.is_ni, "controller_sni": ic.controller.is_sni,
            "dc_loop_gain": ic.dc_loop_gain, "predicted_stable": ic.predicted_stable, "poles_stable": ic.poles_stable,
        }
    return out


def lmis(vehicle: Vehicle | None = None, gains: GainBlock = PAPER_GAINS, *,
         mass_range: Sequence[float] | None = None, tilt_limit_deg: float = TILT_LIMIT_DEG) -> LMIReport:
    """Solve every LMI of the reduced loop of a vehicle and gain set, with the cross-checks.

    Parameters
    ----------
    vehicle
        The vehicle (its mass and gravity); default the paper's.
    gains
        The NNI gains (default the paper's).
    mass_range
        True-mass interval ``(lo, hi)`` of the robust LMIs [kg]; default
        :data:`nniquad.config.MASS_RANGE_FRACTION` of the vehicle's mass.
    tilt_limit_deg
        Tilt limit of the region-of-attraction LMI [deg].

    Returns
    -------
    LMIReport
        The LMI answers (:meth:`LMIReport.table`, :meth:`LMIReport.to_json`).

    Raises
    ------
    GainError
        Non-positive or non-finite data, or ``lo > hi``.
    """

    vehicle = PAPER_VEHICLE if vehicle is None else vehicle
    tilt = finite_number("tilt limit", tilt_limit_deg, error=GainError, positive=True)
    if mass_range is None:
        lo, hi = (f * vehicle.m for f in MASS_RANGE_FRACTION)
    else:
        try:
            lo, hi = (finite_number("mass range", v, error=VehicleError, positive=True) for v in mass_range)
        except ValueError:
            raise VehicleError(f"mass range must be two numbers (LO HI), got {mass_range!r}") from None
        if lo > hi:
            raise VehicleError(f"mass range LO must not exceed HI, got {lo:g} > {hi:g}")
    loop = ReducedLoop.from_vehicle(vehicle, gains)
    results = run_all(loop, mass_range=(lo, hi), tilt_limit_deg=tilt)
    return LMIReport(vehicle, loop, (lo, hi), tilt, tuple(results), loop.poles_and_damping(), _frequency(loop))
