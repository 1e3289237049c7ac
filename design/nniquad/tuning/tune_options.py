"""What to tune and how hard: :class:`TuneOptions`, the budgets and the tuner's constants."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Callable

from nniquad.config import (
    CONTROL_RATE_HZ,
    GAMMA_MAX,
    ROBUST_DELAY_SAMPLES,
    TILT_LIMIT_DEG,
    TUNING_SCENARIO_SEED,
    XI0_NORM_M,
)
from nniquad.control.references import Reference
from nniquad.errors import GainError, NniquadError, VehicleError
from nniquad.laws.base import ControlLaw
from nniquad.laws.classes import LAW_CLASSES
from nniquad.laws.registry import law_named, law_names
from nniquad.scenarios.ranges import DEFAULT_RANGES
from nniquad.validate import finite_int, finite_number

#: ‖ξ_h(0)‖ of the paper's run [m]: the default certified reach.
DEFAULT_ROA_RADIUS_M = XI0_NORM_M

#: Search effort: (Sobol points, distinct starts, optimiser evaluations, extra seeds).  The points and
#: the evaluations are for the 3 coordinates of ``reduced``; the 6 of ``full`` get twice as many of both.
BUDGETS: dict[str, tuple[int, int, int, int]] = {
    "quick": (128, 2, 200, 0),
    "normal": (256, 4, 400, 1),
    "thorough": (1024, 6, 2000, 4),
}

#: Search effort of the robust objective (same fields; the sweep is screened on the nominal run, the
#: optimiser's evaluations are not doubled for the attitude coordinates): a robust candidate runs the
#: 20 tuning scenarios, ~0.5 s on 2 cores, and ``certify --model full`` must stay under 3 minutes.
#: Paper's vehicle, `certify --model full`: 300 evaluations 72 s, p95 3.289 s; 600: 255 s, 3.209 s.
ROBUST_BUDGETS: dict[str, tuple[int, int, int, int]] = {
    "quick": (128, 2, 60, 0),
    "normal": (256, 4, 400, 0),
    "thorough": (1024, 6, 800, 2),
}

#: When no candidate passes every robust scenario on the default horizon, the search is repeated once on a
#: horizon that shows settling times up to this multiple of ``enter_band_s`` (6.9 s, a 20.8 s horizon, for
#: the paper's vehicle): the robust corners of a weaker or slower vehicle settle later (Iris, Crazyflie 2.x).
ROBUST_RETRY_BANDS = 6.0

#: Screened sweep points re-evaluated on the full objective, per optimiser start.
SCREEN_KEEP_PER_START = 8


def robust_budgets(law: ControlLaw) -> dict[str, tuple[int, int, int, int]]:
    """The robust objective's effort per budget for ``law``: :data:`ROBUST_BUDGETS`, with the law's
    :attr:`~nniquad.laws.base.ControlLaw.robust_budget_overrides` applied (the ``sni2`` law's ``normal`` is the
    ``thorough`` search without its extra seeds).

    Parameters
    ----------
    law
        The tuned law.
    """
    out = dict(ROBUST_BUDGETS)
    for budget, (other, seeds) in law.robust_budget_overrides.items():
        base = ROBUST_BUDGETS[other]
        out[budget] = base if seeds is None else base[:3] + (int(seeds),)
    return out


def budget_of(options: "TuneOptions") -> tuple[int, int, int, int]:
    """The (Sobol points, starts, optimiser evaluations, extra seeds) of ``options``' budget, objective and law.

    Parameters
    ----------
    options
        The tuning options.
    """
    if options.robust:
        return robust_budgets(options.law)[options.budget]
    return BUDGETS[options.budget]


#: The optimisers behind :func:`nniquad.tuning.optimizers.minimise`: BIPOP-CMA-ES (pycma), MADS (NOMAD 4).
OPTIMIZERS = ("cma", "nomad")

#: The default optimiser: the better one of ``benchmarks/bench_optimizers.py`` (same budget, five seeds).
DEFAULT_OPTIMIZER = "cma"

#: Actual tilt may exceed the tilt limit by this much [deg].
TILT_SLACK_DEG = 1.0

#: In the robust objective's perturbed scenarios the actual tilt may exceed the limit by this much [deg]:
#: a slower motor or a weaker attitude loop overshoots the tilt command (by 3-15 deg in the slow-motor
#: corners of the Monte Carlo box); the guard is against a flip-like excursion, not against the overshoot.
ROBUST_TILT_SLACK_DEG = 15.0

#: ``full`` margin scenario: motor time constant factor and position noise [m] (100 Hz).
MARGIN_TAU_FACTOR = 1.5
MARGIN_NOISE_M = 0.002

#: The default tuner horizon lets settling times up to this multiple of ``enter_band_s`` count
#: (:func:`honest_horizon_s`): 4 × 1.15 s + 9.2 s hold = 13.8 s for the paper's vehicle.
LONGEST_SETTLING_BANDS = 4.0

#: Share of the global sweep placed on the sector-bound face u = 0 (:func:`initial_design`).
SECTOR_FACE_SHARE = 0.5

#: Largest altitude deviation a ``full`` candidate may show [m].
ALTITUDE_CAP_M = 0.5

#: The robust objective minimises this quantile of the settling times over the tuning scenarios.
ROBUST_QUANTILE = 0.95


#: The tracking objective's cost of an admissible candidate is ``horizon × rms / (rms + this)`` [m]: increasing in
#: the RMS tracking error and below the horizon, where every penalty of the settling objective starts (the
#: optimisers rank candidates; CMA-ES sees only the order).
TRACKING_COST_SCALE_M = 1.0


def default_tracking_window(reference: Reference) -> tuple[float, float]:
    """The window of the tracking objective when none is given [s]: the second period of a periodic reference
    (the first holds the attitude loop's start transient), else the whole reference ``[0, end]``.

    Parameters
    ----------
    reference
        The reference.

    Raises
    ------
    NniquadError
        A reference with neither a period nor an end (give the window).
    """
    period = getattr(reference, "period_s", None)
    if period is not None:
        return float(period), 2.0 * float(period)
    if math.isfinite(reference.end_s) and reference.end_s > 0:
        return 0.0, float(reference.end_s)
    raise NniquadError(f"reference {reference.describe()} has no period and no end: give the tracking window")


#: The objectives (:attr:`TuneOptions.objective`).
OBJECTIVES = ("robust", "nominal")


@dataclass(frozen=True)
class TuneOptions:
    """What to tune and how hard (validated on construction).

    Attributes
    ----------
    model
        ``"reduced"`` or ``"full"``.
    gamma_max
        γ_max of the sector bound, in (0, 1) (paper: 0.8).
    roa_radius_m
        Certified reach of the reduced loop's region-of-attraction LMI required [m]; 0
        switches the check off.  ``None`` (default): ‖ξ_h(0)‖ for the ``paper`` class,
        0 for the ``cascade`` class (its proof is the cascade certificate, not the
        reduced loop) and for the PD laws.
    mass_range
        ``(m_lo, m_hi)`` true masses [kg] the settling time must hold for, or ``None``.
    noise_sigma_m
        Position-noise standard deviation during tuning [m] (100 Hz sample and hold).
    tilt_limit_deg
        Tilt limit [deg].
    budget
        ``"quick"``, ``"normal"`` or ``"thorough"`` (:data:`BUDGETS`).
    seed
        Seed of the Sobol scrambling and of the optimiser.
    horizon_s
        Simulated time per candidate [s]; default :func:`honest_horizon_s` of
        ``LONGEST_SETTLING_BANDS × enter_band_s`` (a settling time counts only when
        the run is seen in the band for ``max(5 s, 2 × settling)`` after it).
    motor_lag
        First-order rotor-speed lag in the ``full`` model (default on).
    tune_attitude
        Tune the attitude natural frequency with the gains (``full``; default on).
    reruns
        Extra seeds for the artefact check; ``None`` takes the budget's.
    controller
        Horizontal law to tune, a registered law's name (:mod:`nniquad.laws`): ``"nni"`` (the paper's,
        default), ``"sni2"`` (the NNI structure with a second-order SNI controller; the same law classes, its
        DC condition in place of the sector bound), or one of the PD comparison laws ``"pd_velocity"`` (true
        velocity) and ``"pd_filtered"`` (filtered derivative of the measurement), tuned on the same inner loops,
        scenarios and rules; a law outside the NI structure has no sector bound and no certified reach
        (``roa_radius_m`` is set to 0 for it).
    law_class
        The class of certified NNI designs searched (:mod:`nniquad.laws.classes`):
        ``"paper"`` (the sector bound holds; the default of the NNI law) or ``"cascade"``
        (the sector bound dropped; the proof is the sampled-data cascade certificate).
        For ``"pd_filtered"``, a class restricts the search to the filtered PDs whose
        NNI image lies in that class's box (:mod:`nniquad.tuning.coordinates`; ``None``, the
        default, searches them all); ``"pd_velocity"`` takes no class.
    rate_hz
        Control rate [Hz] of the ``full`` model's candidates: the position is sampled at
        it and the law runs in discrete time (``SimOptions(controller_sampling="discrete")``),
        what the certificate certifies and ``nniquad export`` writes (default
        :data:`nniquad.config.CONTROL_RATE_HZ`); ``reduced`` runs the paper's continuous loop.
    margin
        ``full`` only: also demand the settling time with the motor time constant
        × :data:`MARGIN_TAU_FACTOR` and position noise :data:`MARGIN_NOISE_M`
        sampled at 100 Hz (default off: the issue's targets are nominal); the cost
        is the worse of the two runs.  The default design sits at the edge of the
        nominal motor lag (``nniquad montecarlo`` shows it); this buys margin for
        settling time.
    objective
        ``"robust"``: minimise the :data:`ROBUST_QUANTILE` quantile of the honest
        settling time over the fixed tuning scenario set
        (:mod:`nniquad.tuning.robust_scenarios`), every scenario required to settle without
        altitude loss, divergence or actual tilt above the limit + 1°; ``"nominal"``:
        the single nominal scenario (and ``mass_range`` / ``margin``).  ``None``
        (default) is ``"robust"`` for ``full`` and ``"nominal"`` for ``reduced``
        (the reduced model has no plant to perturb).
    scenario_seed
        Seed of the robust scenario set (default :data:`nniquad.config.TUNING_SCENARIO_SEED`);
        a benchmark Monte Carlo study must use a different seed.
    scenario_noise_range_m
        ``(σ_lo, σ_hi)`` [m]: the position-noise standard deviations of the robust
        scenario set (the box corners take ``σ_hi``, the random draws are uniform in
        the range; one noise value per position sample at :attr:`rate_hz`).
        ``None`` (default): the Monte Carlo default range
        (:data:`nniquad.scenarios.ranges.DEFAULT_RANGES`), resolved by
        :attr:`robust_noise_range_m`; unused by the nominal objective.  Set it to
        the sensor's noise: a velocity-free law differentiates the measured
        position, so the noise it must tolerate limits how fast it can be
        (docs/notes/robustness.md).
    require_margins
        ``full`` only: demand gain margin >= ``config.REQUIRED_GM_DB`` both ways at both
        break points of the linearised cascade (:mod:`nniquad.analysis.fast_margins`),
        and report the phase margins against ``config.REQUIRED_PM_DEG``; a candidate
        that misses a required margin is ranked above every admissible one.  ``None``
        (default) is on for ``full`` with the NNI law and with a filtered PD tuned in a
        law class (computed on its NNI image).
    require_pm
        Also rank the phase-margin shortfall (``--require-pm``).  Off by default: PM >= 45°
        at the horizontal break point is out of reach of this law under the sector
        bound (at most asin(γ_max/(2-γ_max)) = 41.8° on the ideal double integrator,
        :func:`nniquad.certificates.build.sector_pm_ceiling_deg`), so every candidate
        misses it and the search, ranking the shortfall first, trades settling time
        for a few degrees (paper's vehicle, quick budget: robust p95 3.21 s -> 4.53 s
        for +2° horizontal and +6° attitude PM; docs/notes/tuning.md).
    optimizer
        The optimiser after the sweep, one of :data:`OPTIMIZERS` (default
        :data:`DEFAULT_OPTIMIZER`; :mod:`nniquad.tuning.optimizers`).
    reference
        ``None`` (default): the objective above, unchanged.  A reference
        (:mod:`nniquad.control.references`): the **tracking objective**, minimise the RMS tracking error
        over :attr:`tracking_window` of the nominal run started on the reference with its velocity (the law's
        state at rest for that start, :attr:`feedforward` as given), subject to everything above: the settling
        cost of :attr:`objective` must be admissible (the design settles from the standard start, every robust
        scenario with ``"robust"``), the sector bound, the certified reach and the margins; a tracking run that
        is lost or not finite is inadmissible (:func:`nniquad.tuning.objective.tracking_cost`).
    feedforward
        With a reference: add its acceleration to the command (:attr:`nniquad.sim.SimOptions.feedforward`).
    feedforward_lead_s
        With feedforward: read it this much ahead [s] (:attr:`nniquad.sim.SimOptions.feedforward_lead_s`).
    tracking_window
        ``(t0, t1)`` [s] of the tracking RMS; the tracking run lasts ``t1``.  ``None``: :func:`default_tracking_window`.
    scenario_wind_fraction_range
        ``(lo, hi)``: the constant wind force of the robust scenario set as a fraction of ``m g`` (the box corners
        take ``hi``).  ``None`` (default): the Monte Carlo default range, resolved by
        :attr:`robust_wind_fraction_range`.  A tuning record states the range it was tuned on; one that states
        none was tuned on :data:`nniquad.config.FORMER_WIND_WEIGHT_FRACTION_RANGE`.
    delay_samples
        Measurement delay [samples at :attr:`rate_hz`] of the robust objective's perturbed scenarios (the
        position reaches the law that many control periods late, :attr:`nniquad.sim.SimOptions.delay_samples`);
        the nominal run has none.  ``None`` (default): :data:`nniquad.config.ROBUST_DELAY_SAMPLES` with the
        robust objective, else 0.
    """

    model: str = "reduced"
    gamma_max: float = GAMMA_MAX
    roa_radius_m: float | None = None
    mass_range: tuple[float, float] | None = None
    noise_sigma_m: float = 0.0
    tilt_limit_deg: float = TILT_LIMIT_DEG
    budget: str = "normal"
    seed: int = 0
    horizon_s: float | None = None
    motor_lag: bool = True
    tune_attitude: bool = True
    reruns: int | None = None
    margin: bool = False
    objective: str | None = None
    scenario_seed: int = TUNING_SCENARIO_SEED
    require_margins: bool | None = None
    require_pm: bool = False
    controller: str = "nni"
    optimizer: str = DEFAULT_OPTIMIZER
    law_class: str | None = None
    rate_hz: float = CONTROL_RATE_HZ
    scenario_noise_range_m: tuple[float, float] | None = None
    reference: Reference | None = None
    feedforward: bool = False
    feedforward_lead_s: float = 0.0
    tracking_window: tuple[float, float] | None = None
    delay_samples: int | None = None
    scenario_wind_fraction_range: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        self._check_reference()
        if self.controller not in law_names():
            raise NniquadError(f"controller must be one of {', '.join(law_names())}, got {self.controller!r}")
        if self.law_class is not None and self.law_class not in LAW_CLASSES:
            raise NniquadError(f"law class must be one of {', '.join(LAW_CLASSES)}, got {self.law_class!r}")
        try:
            object.__setattr__(self, "law_class", self.law.check_class(self.law_class))
        except ValueError as exc:
            raise NniquadError(str(exc)) from None
        # a positive number here; tune() checks it is a period of whole RK4 steps (nniquad.sim.options.check_rate_hz)
        object.__setattr__(self, "rate_hz", finite_number("rate", self.rate_hz, error=NniquadError, positive=True))
        if self.model not in ("reduced", "full"):
            raise NniquadError(f"tuning model must be 'reduced' or 'full', got {self.model!r}")
        g = _finite("gamma_max", self.gamma_max)
        if not 0.0 < g < 1.0:
            raise GainError(f"gamma_max must lie in (0, 1), got {self.gamma_max!r}")
        if self.roa_radius_m is None:  # the reduced loop's reach is the paper class's statement
            object.__setattr__(self, "roa_radius_m", DEFAULT_ROA_RADIUS_M if self.law_class == "paper"
                               and self.law.ni_structure else 0.0)
        r = _finite("roa radius", self.roa_radius_m)
        if r < 0:
            raise NniquadError(f"roa radius must not be negative, got {self.roa_radius_m!r}")
        if self.mass_range is not None:
            object.__setattr__(self, "mass_range", _range("mass range", self.mass_range, "0 < LO <= HI",
                                                          lambda lo, hi: 0 < lo <= hi, VehicleError))
        if _finite("noise sigma", self.noise_sigma_m) < 0:
            raise NniquadError(f"noise sigma must not be negative, got {self.noise_sigma_m!r}")
        t = _finite("tilt limit", self.tilt_limit_deg)
        if not 0 < t < 90:
            raise NniquadError(f"tilt limit must lie in (0, 90) deg, got {self.tilt_limit_deg!r}")
        if self.budget not in BUDGETS:
            raise NniquadError(f"budget must be one of {', '.join(BUDGETS)}, got {self.budget!r}")
        if self.horizon_s is not None and _finite("horizon", self.horizon_s) <= 0:
            raise NniquadError(f"horizon must be positive, got {self.horizon_s!r}")
        if not isinstance(self.seed, int) or self.seed < 0:
            raise NniquadError(f"seed must be a non-negative integer, got {self.seed!r}")
        if self.optimizer not in OPTIMIZERS:
            raise NniquadError(f"optimizer must be one of {', '.join(OPTIMIZERS)}, got {self.optimizer!r}")
        if self.reruns is not None and (not isinstance(self.reruns, int) or self.reruns < 0):
            raise NniquadError(f"reruns must be a non-negative integer, got {self.reruns!r}")
        if self.objective is None:
            object.__setattr__(self, "objective", "robust" if self.model == "full" else "nominal")
        if self.objective not in OBJECTIVES:
            raise NniquadError(f"objective must be one of {', '.join(OBJECTIVES)}, got {self.objective!r}")
        if self.objective == "robust" and self.model != "full":
            raise NniquadError("the robust objective perturbs the full vehicle: use model 'full' or objective 'nominal'")
        if isinstance(self.scenario_seed, bool) or not isinstance(self.scenario_seed, int) or self.scenario_seed < 0:
            raise NniquadError(f"scenario seed must be a non-negative integer, got {self.scenario_seed!r}")
        if self.scenario_noise_range_m is not None:
            object.__setattr__(self, "scenario_noise_range_m",
                               _range("scenario noise range", self.scenario_noise_range_m, "0 <= LO <= HI (m)",
                                      lambda lo, hi: 0.0 <= lo <= hi, NniquadError))
        if self.scenario_wind_fraction_range is not None:
            object.__setattr__(self, "scenario_wind_fraction_range",
                               _range("scenario wind range", self.scenario_wind_fraction_range,
                                      "0 <= LO <= HI (fraction of m g)", lambda lo, hi: 0.0 <= lo <= hi, NniquadError))
        if self.require_margins is None:  # the cascade margins are those of the NNI law's split
            object.__setattr__(self, "require_margins", self.model == "full" and self.nni_image)
        if self.require_margins and not self.nni_image:
            raise NniquadError("the margin requirement is computed on the NNI cascade: switch it off for a PD law "
                               "(or tune the filtered PD in a law class: its NNI image is then checked)")
        if self.require_margins and self.model != "full":
            raise NniquadError("the margin requirement applies to the full cascade: use model 'full'")
        object.__setattr__(self, "require_margins", bool(self.require_margins))
        delay = (ROBUST_DELAY_SAMPLES if self.robust else 0) if self.delay_samples is None else self.delay_samples
        # kept when the sweep screens on the nominal run (tuning.search): only the robust scenarios read it
        object.__setattr__(self, "delay_samples", finite_int("delay_samples", delay, minimum=0))
        object.__setattr__(self, "gamma_max", g)
        # the PD laws have no sector bound, hence no certified region: the reach check does not apply
        object.__setattr__(self, "roa_radius_m", r if self.law.ni_structure else 0.0)

    def _check_reference(self) -> None:
        """The tracking fields: a reference for each of the others, and a window of the run's times."""
        if self.reference is None:
            for name, given in (("feedforward", self.feedforward), ("feedforward lead", self.feedforward_lead_s),
                                ("tracking window", self.tracking_window is not None)):
                if given:
                    raise NniquadError(f"{name} needs a reference")
            return
        if not isinstance(self.reference, Reference):
            raise NniquadError(f"reference must be a Reference, got {type(self.reference).__name__}")
        if _finite("feedforward lead", self.feedforward_lead_s) < 0:
            raise NniquadError(f"feedforward lead must not be negative, got {self.feedforward_lead_s!r}")
        if self.feedforward_lead_s and not self.feedforward:
            raise NniquadError("a feedforward lead needs the feedforward")
        window = default_tracking_window(self.reference) if self.tracking_window is None else self.tracking_window
        object.__setattr__(self, "tracking_window", _range("tracking window", window, "0 <= T0 < T1",
                                                           lambda lo, hi: 0 <= lo < hi, NniquadError))

    @property
    def tracking(self) -> bool:
        """Whether the tracking objective is used (a reference is given)."""
        return self.reference is not None

    @property
    def law(self) -> ControlLaw:
        """The tuned law (:mod:`nniquad.laws`)."""
        return law_named(self.controller, error=NniquadError)

    @property
    def dims(self) -> int:
        """Number of search coordinates: the law's gains, plus 3 with the attitude loop (``full``)."""
        return self.law.dims(self.law_class) + (3 if (self.model == "full" and self.tune_attitude) else 0)

    @property
    def nni_image(self) -> bool:
        """Whether the candidates are designs of the NI structure in a class: the NNI or ``sni2`` law, or a filtered
        PD in a class (its NNI image)."""
        return self.law.in_class(self.law_class)

    @property
    def robust(self) -> bool:
        """Whether the robust objective is used."""
        return self.objective == "robust"

    @property
    def robust_noise_range_m(self) -> tuple[float, float]:
        """The position-noise σ range of the robust scenario set [m]: :attr:`scenario_noise_range_m`, or the Monte
        Carlo default."""
        if self.scenario_noise_range_m is not None:
            return self.scenario_noise_range_m
        return DEFAULT_RANGES.noise_sigma_m

    @property
    def robust_wind_fraction_range(self) -> tuple[float, float]:
        """The wind range of the robust scenario set [fraction of m g]: :attr:`scenario_wind_fraction_range`, or the
        Monte Carlo default."""
        if self.scenario_wind_fraction_range is not None:
            return self.scenario_wind_fraction_range
        return DEFAULT_RANGES.wind_weight_fraction

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        for key in ("mass_range", "scenario_noise_range_m", "scenario_wind_fraction_range"):
            d[key] = None if d[key] is None else list(d[key])
        if self.reference is None:  # the settling objective's record as it always was
            for key in ("reference", "feedforward", "feedforward_lead_s", "tracking_window"):
                del d[key]
        else:
            d["reference"] = self.reference.to_json()
            d["tracking_window"] = list(self.tracking_window)
        return d


def _finite(name: str, value: Any) -> float:
    return finite_number(name, value)


def _range(name: str, value: Any, rule: str, holds: Callable[[float, float], bool],
           error: type[NniquadError]) -> tuple[float, float]:
    """``value`` as a pair ``(LO, HI)`` of finite numbers for which ``holds(LO, HI)``, else ``error`` naming
    ``name`` and the ``rule``."""
    try:
        pair = tuple(value)
    except TypeError:
        pair = ()
    if len(pair) != 2:
        raise error(f"{name} must be a pair (LO, HI) with {rule}, got {value!r}")
    lo, hi = (_finite(name, v) for v in pair)
    if not holds(lo, hi):
        raise error(f"{name} must satisfy {rule}, got {lo:g} {hi:g}")
    return lo, hi
