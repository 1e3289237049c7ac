"""Monte Carlo scenarios: the perturbation ranges, the study setup and the seeded draw of each scenario.

See :mod:`nniquad.study` for the ranges and why they were chosen, and for the
reproducibility rule: scenario ``i`` of seed ``S`` comes from its own stream.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any, Mapping, Sequence

import numpy as np

from nniquad.config import (ALTITUDE_LIMIT_M, BAND_FRACTION, CONTROL_RATE_HZ, DT_S, MC_WITHIN_RIM_FRACTION, OUTPUT_DT_S,
                             TAU_MOTOR_FACTOR_RANGE, TILT_LIMIT_DEG, WIND_WEIGHT_FRACTION_RANGE, XI0_M)
from nniquad.errors import MonteCarloError
from nniquad.control.gains import NI_LAWS
from nniquad.sim import SimOptions, SimParams, to_gains

__all__ = [
    "ScenarioRanges",
    "DEFAULT_RANGES",
    "StudySetup",
    "Scenario",
    "study_setup",
    "study_setup_from",
    "draw_scenario",
    "draw_scenarios",
    "DEFAULT_HORIZON_S",
    "certificate_rate_hz",
    "within_certificate_ranges",
    "BOX_KEYS",
]

#: Default simulated time of a scenario [s].
DEFAULT_HORIZON_S = 20.0




def _pair(name: str, value: Any, *, lo: float | None = None, hi: float | None = None,
          positive: bool = False) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in value)
    except (TypeError, ValueError):
        raise MonteCarloError(f"{name} must be a pair of numbers (low, high), got {value!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)):
        raise MonteCarloError(f"{name} must be finite, got ({a:g}, {b:g})")
    if a > b:
        raise MonteCarloError(f"{name}: low {a:g} is above high {b:g}")
    if positive and a <= 0:
        raise MonteCarloError(f"{name} must be positive, got low {a:g}")
    if lo is not None and a < lo:
        raise MonteCarloError(f"{name} must be at least {lo:g}, got low {a:g}")
    if hi is not None and b > hi:
        raise MonteCarloError(f"{name} must be at most {hi:g}, got high {b:g}")
    return (a, b)


@dataclass(frozen=True)
class ScenarioRanges:
    """Ranges of the random perturbations; every one is drawn uniformly (see the module docstring).

    Attributes
    ----------
    mass_factor
        True mass / nominal mass (default 0.8-1.2).
    inertia_factor
        True inertia / nominal, drawn independently per axis (default 0.8-1.2);
        ``Jz`` is capped at ``Jx + Jy`` (rigid-body triangle inequality).
    attitude_gain_factor
        Factor on the attitude-loop torques (default 0.7-1.3).
    tau_motor_factor
        Motor time constant / the vehicle's nominal (default
        :data:`nniquad.config.TAU_MOTOR_FACTOR_RANGE`, 0.5-2); used unless ``tau_motor_s`` is given.
    tau_motor_s
        Absolute motor time constant range [s] instead of the factor (default ``None``;
        at least ``2 dt``).
    noise_sigma_m
        Standard deviation of the position noise [m] (default 0-0.02).
    noise_rate_hz
        Position-sensor sample rate [Hz], also the control rate (default 100; the
        measurement is sampled and held, and the law runs in discrete time at
        this rate unless the study setup says otherwise).
    wind_weight_fraction
        Magnitude of the constant horizontal wind force as a fraction of the
        nominal weight ``m g`` (default :data:`nniquad.config.WIND_WEIGHT_FRACTION_RANGE`,
        0-6 %), direction uniform; used unless ``wind_N`` is given.
    wind_N
        Absolute wind force magnitude range [N] instead of the fraction (default ``None``).
    max_displacement_m
        Cap on the initial displacement radius [m] (default 5); the radius is
        ``min(certified region, cap)``.
    altitude_limit_m
        An altitude deviation beyond this [m] is "altitude lost" (default
        :data:`nniquad.config.ALTITUDE_LIMIT_M`).
    rim_fraction
        Fraction of the starts drawn on the rim of the displacement disk, the others uniformly over it
        (default 0; ``--within-certificate``: :data:`nniquad.config.MC_WITHIN_RIM_FRACTION`).
    """

    mass_factor: tuple[float, float] = (0.8, 1.2)
    inertia_factor: tuple[float, float] = (0.8, 1.2)
    attitude_gain_factor: tuple[float, float] = (0.7, 1.3)
    tau_motor_factor: tuple[float, float] = TAU_MOTOR_FACTOR_RANGE
    tau_motor_s: tuple[float, float] | None = None
    noise_sigma_m: tuple[float, float] = (0.0, 0.02)
    noise_rate_hz: float = 100.0
    wind_weight_fraction: tuple[float, float] = WIND_WEIGHT_FRACTION_RANGE
    wind_N: tuple[float, float] | None = None
    max_displacement_m: float = 5.0
    altitude_limit_m: float = ALTITUDE_LIMIT_M
    rim_fraction: float = 0.0

    def __post_init__(self) -> None:
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        set_("mass_factor", _pair("mass factor range", self.mass_factor, positive=True))
        set_("inertia_factor", _pair("inertia factor range", self.inertia_factor, positive=True))
        set_("attitude_gain_factor", _pair("attitude-gain factor range", self.attitude_gain_factor, positive=True))
        set_("tau_motor_factor", _pair("motor time-constant factor range", self.tau_motor_factor, positive=True))
        if self.tau_motor_s is not None:
            set_("tau_motor_s", _pair("motor time-constant range", self.tau_motor_s, lo=0.002))
        set_("noise_sigma_m", _pair("noise sigma range", self.noise_sigma_m, lo=0.0))
        set_("wind_weight_fraction", _pair("wind fraction-of-weight range", self.wind_weight_fraction, lo=0.0))
        if self.wind_N is not None:
            set_("wind_N", _pair("wind force range", self.wind_N, lo=0.0))
        for name in ("noise_rate_hz", "max_displacement_m", "altitude_limit_m"):
            v = getattr(self, name)
            try:
                fv = float(v)
            except (TypeError, ValueError):
                raise MonteCarloError(f"{name} must be a number, got {v!r}") from None
            if not math.isfinite(fv) or fv <= 0:
                raise MonteCarloError(f"{name} must be finite and positive, got {v!r}")
            set_(name, fv)
        if self.noise_rate_hz > 1000.0:
            raise MonteCarloError(f"noise_rate_hz {self.noise_rate_hz:g} exceeds the 1 kHz integration rate")
        rim = self.rim_fraction
        if isinstance(rim, bool) or not isinstance(rim, (int, float)) or not 0.0 <= rim < 1.0:
            raise MonteCarloError(f"rim_fraction must be a number in [0, 1), got {rim!r}")
        set_("rim_fraction", float(rim))

    def with_(self, **changes: Any) -> "ScenarioRanges":
        """Copy with some ranges changed (validated again)."""
        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


DEFAULT_RANGES = ScenarioRanges()


# =============================================================================== study setup


@dataclass(frozen=True)
class StudySetup:
    """What every scenario of a study shares, taken from the certificate.

    Attributes
    ----------
    base_params
        Nominal :class:`nniquad.sim.SimParams` vector (certificate vehicle,
        gains, inner loops, tilt limit; motor lag on; sampled measurement).
    xi0_nominal_m
        The certificate's initial position (sets the settling band).
    region_m
        Radius of the initial-displacement disk: ``min(certified region, cap)``.
    band_m
        Settling band radius [m] (2 % of ``‖xi0_nominal_m‖``).
    horizon_s, dt_s, output_dt_s
        Simulated time, RK4 step and output sample period [s].
    label
        Certificate identification (digest or name) for the report.
    controller
        Horizontal law of :attr:`base_params` (``"nni"``, ``"pd_velocity"``,
        ``"pd_filtered"``, ``"sni2"``: :data:`nniquad.sim.CONTROLLERS`); it fixes the layout
        of the parameter vector.
    controller_sampling
        ``"discrete"`` (the law in discrete time at the sample rate, what
        flies) or ``"held"`` (the controller integrated continuously on the held
        measurement): :attr:`nniquad.sim.SimOptions.controller_sampling`.
    """

    base_params: tuple[float, ...]
    xi0_nominal_m: tuple[float, float]
    region_m: float
    band_m: float
    horizon_s: float = DEFAULT_HORIZON_S
    dt_s: float = DT_S
    output_dt_s: float = OUTPUT_DT_S
    label: str = ""
    controller: str = "nni"
    controller_sampling: str = "held"

    @property
    def base(self) -> SimParams:
        """:attr:`base_params` as a :class:`nniquad.sim.SimParams` (the :attr:`controller`'s layout)."""
        return SimParams.from_vector(self.base_params, self.controller)

    def to_json(self) -> dict[str, Any]:
        b = self.base
        return {
            "certificate": self.label,
            "controller": self.controller,
            "gains": b.gains.as_dict(),
            "nominal_mass_kg": b.nominal.m,
            "tilt_limit_deg": math.degrees(b.run.tilt_limit),
            "xi0_nominal_m": list(self.xi0_nominal_m),
            "displacement_radius_m": self.region_m,
            "settling_band_m": self.band_m,
            "horizon_s": self.horizon_s,
            "dt_s": self.dt_s,
            "output_dt_s": self.output_dt_s,
            "controller_sampling": self.controller_sampling,
            "rate_hz": 1.0 / b.run.sample_period,
        }


def _cert_float(value: Any) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) and v > 0 else None


def study_setup_from(vehicle: Any, gains: Any, *, inner: Any = None, tilt_limit_deg: float = TILT_LIMIT_DEG,
                     xi0_m: Sequence[float] = XI0_M, region_m: float | None = None,
                     ranges: ScenarioRanges = DEFAULT_RANGES, horizon_s: float = DEFAULT_HORIZON_S,
                     label: str = "", controller_sampling: str | None = None) -> StudySetup:
    """The shared part of a study from a vehicle, a gain set and inner-loop gains (no certificate).

    ``gains`` is any controller's gain block (:class:`~nniquad.control.gains.Gains`,
    :class:`~nniquad.control.gains.PDGains`, :class:`~nniquad.control.gains.PDFilteredGains`)
    or a mapping / tuple of NNI gains; the block's type picks the law, so the PD
    comparison laws are studied on the same scenarios as the NNI law.

    Parameters
    ----------
    vehicle
        The nominal vehicle (:class:`nniquad.model.vehicle.Vehicle`).
    gains
        The horizontal law's gain block (see above).
    inner
        Inner-loop gains (default :data:`nniquad.control.gains.DEFAULT_INNER_LOOP_GAINS`).
    tilt_limit_deg
        Tilt limit [deg].
    xi0_m
        The nominal initial position [m]; its norm sets the settling band (2 %).
    region_m
        Radius of the initial-displacement disk [m] (default ``‖xi0_m‖``), capped at
        ``ranges.max_displacement_m``.
    ranges
        The perturbation ranges (their noise rate and displacement cap are used here).
    horizon_s
        Simulated time per scenario [s].
    label
        Identification of the design for the report.
    controller_sampling
        ``"discrete"`` or ``"held"``; default ``"discrete"`` for every law (NNI, ``sni2`` and the PD laws: the
        discrete-time controller at ``ranges.noise_rate_hz``: what flies, and what the
        tuner ranks; the PD laws' discrete forms are in :mod:`nniquad.sim.models`).

    Returns
    -------
    StudySetup

    Raises
    ------
    MonteCarloError
        A non-positive horizon, a bad initial position, or a rate the discrete
        controller cannot run at (its period must be a whole number of RK4 steps).
    """
    h = _cert_float(horizon_s)
    if h is None:
        raise MonteCarloError(f"horizon must be a positive number of seconds, got {horizon_s!r}")
    try:
        xi0 = tuple(float(v) for v in xi0_m)
        if len(xi0) != 2 or not all(math.isfinite(v) for v in xi0) or math.hypot(*xi0) <= 0:
            raise ValueError
    except (TypeError, ValueError):
        raise MonteCarloError(f"initial position xi0_m must be a non-zero pair of numbers, got {xi0_m!r}") from None
    block = gains if hasattr(gains, "controller") else to_gains(gains, "nni")
    sampling = controller_sampling or "discrete"
    if sampling not in ("discrete", "held"):
        raise MonteCarloError(f"controller sampling of a study must be 'discrete' or 'held', got {sampling!r}")
    if sampling == "discrete":
        from nniquad.sim.options import check_rate_hz

        check_rate_hz(ranges.noise_rate_hz, DT_S, option="rate", error=MonteCarloError)
    opts: dict[str, Any] = {"model": "full", "horizon_s": h, "motor_lag": True, "controller_sampling": sampling,
                            "noise_rate_hz": ranges.noise_rate_hz, "tilt_limit_deg": tilt_limit_deg}
    if inner is not None:
        opts["inner"] = inner
    options = SimOptions(**opts)
    base = SimParams.from_options(vehicle, block, options)
    region = _cert_float(region_m)
    if region is None:
        region = math.hypot(*xi0)
    return StudySetup(
        base_params=tuple(float(v) for v in base.vector()),
        xi0_nominal_m=(xi0[0], xi0[1]),
        region_m=min(region, ranges.max_displacement_m),
        band_m=BAND_FRACTION * math.hypot(*xi0),
        horizon_s=h,
        dt_s=options.dt_s,
        output_dt_s=options.output_dt_s,
        label=label,
        controller=base.controller,
        controller_sampling=sampling,
    )


def _certificate_label(cert: Mapping[str, Any]) -> str:
    for key in ("digest", "sha256"):
        v = cert.get(key)
        if isinstance(v, Mapping):
            v = v.get("sha256") or v.get("value")
        if isinstance(v, str) and v:
            return f"sha256:{v[:16]}" if not v.startswith("sha256") else v[:23]
    return str(cert.get("name", ""))


def study_setup(cert: Mapping[str, Any] | StudySetup, ranges: ScenarioRanges = DEFAULT_RANGES, *,
                horizon_s: float | None = None, region_m: float | None = None) -> StudySetup:
    """The shared part of a study from a loaded certificate (:func:`nniquad.certificates.certificate.load_certificate`).

    ``horizon_s`` defaults to :data:`DEFAULT_HORIZON_S` for a certificate.  A
    :class:`StudySetup` is returned as it is (its own horizon and displacement
    radius; ``ranges`` is not applied again), with ``horizon_s`` replaced only
    when one is given.

    Gains, vehicle and inner-loop gains come from
    :func:`nniquad.certificates.certificate.certificate_gains`, ``certificate_vehicle`` and
    ``certificate_inner_loop``; the displacement radius from
    ``region_of_attraction.max_displacement_m`` (the nominal ``‖xi0_m‖`` when the
    certificate states no region), capped at ``ranges.max_displacement_m``;
    ``region_m`` replaces the certificate's region (e.g. the cascade's,
    :func:`within_certificate_ranges`), capped the same way; the settling band
    is then at most ``BAND_FRACTION`` (2 %) of that radius, so a run starting
    in a region narrower than the normal band must still be seen to converge.

    Raises
    ------
    MonteCarloError
        Bad horizon, or a certificate without a usable initial position.
    """
    if isinstance(cert, StudySetup):
        if horizon_s is None or horizon_s == cert.horizon_s:
            return cert
        h = _cert_float(horizon_s)
        if h is None:
            raise MonteCarloError(f"horizon must be a positive number of seconds, got {horizon_s!r}")
        return replace(cert, horizon_s=h)
    from nniquad.certificates import certificate as C

    roa = cert.get("region_of_attraction")
    tilt = _cert_float(cert.get("tilt_limit_deg"))
    setup = study_setup_from(
        C.certificate_vehicle(cert), C.certificate_gains(cert), inner=C.certificate_inner_loop(cert),
        tilt_limit_deg=TILT_LIMIT_DEG if tilt is None else tilt, xi0_m=cert.get("xi0_m", XI0_M),
        region_m=region_m if region_m is not None else
        (roa.get("max_displacement_m") if isinstance(roa, Mapping) else None),
        ranges=ranges, horizon_s=DEFAULT_HORIZON_S if horizon_s is None else horizon_s,
        label=_certificate_label(cert),
    )
    if region_m is not None:
        # a region narrower than the normal band (2 % of the nominal start): a run must converge to 2 % of the
        # region's radius, or a start inside the band would count as settled at 0 s and prove nothing
        setup = replace(setup, band_m=min(setup.band_m, BAND_FRACTION * setup.region_m))
    return setup


# =============================================================================== scenarios


@dataclass(frozen=True)
class Scenario:
    """One perturbed run: everything :func:`run_scenarios` needs (picklable, a few hundred bytes).

    Attributes
    ----------
    index, study_seed
        The scenario is stream ``index`` of seed ``study_seed`` (rerun it with
        ``--seed study_seed --rerun index``).
    params
        The perturbed :class:`nniquad.sim.SimParams` vector.
    xi0_m
        Initial horizontal position [m], at rest.
    noise_sigma_m, noise_rate_hz, noise_seed
        Position noise and the seed of its sequence.
    horizon_s, dt_s, output_dt_s
        Timing [s].
    band_m, xi0_nominal_norm_m
        Settling band radius [m] and the distance it is 2 % of.
    altitude_limit_m
        Altitude deviation counted as divergence [m].
    factors
        The drawn factors (mass, inertia per axis, attitude gain), for the report.
    controller
        Horizontal law (the layout of :attr:`params`).
    controller_sampling
        ``"discrete"`` or ``"held"`` (:attr:`StudySetup.controller_sampling`).
    """

    index: int
    study_seed: int
    params: tuple[float, ...]
    xi0_m: tuple[float, float]
    noise_sigma_m: float
    noise_rate_hz: float
    noise_seed: int
    horizon_s: float
    dt_s: float
    output_dt_s: float
    band_m: float
    altitude_limit_m: float
    factors: tuple[tuple[str, float], ...] = ()
    controller: str = "nni"
    controller_sampling: str = "held"

    @property
    def sim_params(self) -> SimParams:
        """:attr:`params` as a :class:`nniquad.sim.SimParams`."""
        return SimParams.from_vector(self.params, self.controller)

    def with_params(self, **changes: Any) -> "Scenario":
        """Copy with some parameters changed, by group (e.g. ``plant={"m": 3.0}`` for a vehicle that cannot hover).

        Keywords as :meth:`nniquad.sim.SimParams.with_`.
        """
        return replace(self, params=tuple(float(v) for v in self.sim_params.with_(**changes).vector()))

    def equilibrium_m(self) -> tuple[float, float]:
        """Static equilibrium under the constant wind (:func:`nniquad.control.gains.wind_equilibrium_m`)."""
        from nniquad.control.gains import wind_equilibrium_m

        p = self.sim_params
        return wind_equilibrium_m(p.gains, p.nominal.m, (p.run.wind_x, p.run.wind_y))

    def describe(self) -> dict[str, Any]:
        """The drawn quantities with units (JSON ready)."""
        sp = self.sim_params
        p, w = sp.plant, sp.run
        wind = math.hypot(w.wind_x, w.wind_y)
        return {
            "mass_kg": p.m,
            **{f"{k}_factor": v for k, v in self.factors},
            "Jx_kg_m2": p.Jx, "Jy_kg_m2": p.Jy, "Jz_kg_m2": p.Jz,
            "attitude_gain": sp.inner.attitude_gain_scale,
            "tau_motor_s": p.tau_motor,
            "thrust_to_weight": 4 * p.b * p.omega_max**2 / (p.m * p.g),
            "noise_sigma_m": self.noise_sigma_m,
            "wind_N": [w.wind_x, w.wind_y],
            "wind_magnitude_N": wind,
            "wind_fraction_of_weight": wind / (sp.nominal.m * sp.nominal.g),
            "wind_direction_deg": math.degrees(math.atan2(w.wind_y, w.wind_x)) % 360.0 if wind > 0 else 0.0,
            "xi0_m": list(self.xi0_m),
            "displacement_m": math.hypot(*self.xi0_m),
        }


def _stream(seed: int, index: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))


def _check_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise MonteCarloError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def draw_scenario(index: int, seed: int, ranges: ScenarioRanges, setup: StudySetup) -> Scenario:
    """Scenario ``index`` of seed ``seed``: independent of how many others are drawn.

    Draw order from the scenario's stream: mass factor, inertia factors (x, y,
    z), attitude-gain factor, motor time constant, noise σ, wind magnitude,
    wind direction, displacement radius (``R √u``, uniform over the disk; with a rim fraction ``f``,
    ``R √min(1, u / (1 - f))``: the same draw puts a fraction ``f`` on the rim, the rest uniform),
    displacement direction, noise seed.
    """
    seed = _check_seed(seed)
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
        raise MonteCarloError(f"scenario index must be a non-negative integer, got {index!r}")
    base = setup.base
    tau_range = (ranges.tau_motor_s if ranges.tau_motor_s is not None
                 else tuple(base.plant.tau_motor * f for f in ranges.tau_motor_factor))
    if 2 * setup.dt_s > tau_range[0] + 1e-15:
        raise MonteCarloError(f"motor time constant must be at least 2 dt = {2 * setup.dt_s:g} s for RK4")
    rng = _stream(seed, int(index))
    u = lambda r: float(rng.uniform(r[0], r[1]))  # noqa: E731
    f_m = u(ranges.mass_factor)
    f_J = [u(ranges.inertia_factor) for _ in range(3)]
    f_att = u(ranges.attitude_gain_factor)
    tau = u(tau_range)  # the same stream position for a factor or an absolute range
    sigma = u(ranges.noise_sigma_m)
    weight = base.nominal.m * base.nominal.g
    wind = u(ranges.wind_N if ranges.wind_N is not None
             else tuple(weight * f for f in ranges.wind_weight_fraction))  # same stream position either way
    wdir = float(rng.uniform(0.0, 2 * math.pi))
    radius = setup.region_m * math.sqrt(min(1.0, float(rng.uniform(0.0, 1.0)) / (1.0 - ranges.rim_fraction)))
    rdir = float(rng.uniform(0.0, 2 * math.pi))
    noise_seed = int(rng.integers(0, 2**63 - 1))
    plant = base.plant
    Jx, Jy = plant.Jx * f_J[0], plant.Jy * f_J[1]
    Jz = min(plant.Jz * f_J[2], Jx + Jy)
    params = base.with_(
        plant={"m": plant.m * f_m, "Jx": Jx, "Jy": Jy, "Jz": Jz, "tau_motor": tau},
        inner={"attitude_gain_scale": base.inner.attitude_gain_scale * f_att},
        run={"motor_lag": 1.0, "wind_x": wind * math.cos(wdir), "wind_y": wind * math.sin(wdir),
             "sample_hold": 1.0, "dt": setup.dt_s,
             "discrete": 1.0 if setup.controller_sampling == "discrete" else 0.0,
             "sample_period": 1.0 / ranges.noise_rate_hz},
    )
    return Scenario(
        index=int(index), study_seed=seed, params=tuple(float(v) for v in params.vector()),
        xi0_m=(radius * math.cos(rdir), radius * math.sin(rdir)),
        noise_sigma_m=sigma, noise_rate_hz=ranges.noise_rate_hz, noise_seed=noise_seed,
        horizon_s=setup.horizon_s, dt_s=setup.dt_s, output_dt_s=setup.output_dt_s,
        band_m=setup.band_m, altitude_limit_m=ranges.altitude_limit_m,
        factors=(("mass", f_m), ("Jx", f_J[0]), ("Jy", f_J[1]), ("Jz", f_J[2]), ("attitude_gain", f_att)),
        controller=setup.controller, controller_sampling=setup.controller_sampling,
    )


def draw_scenarios(n: int, seed: int, ranges: ScenarioRanges = DEFAULT_RANGES,
                   cert: Mapping[str, Any] | StudySetup | None = None, *,
                   horizon_s: float | None = None) -> list[Scenario]:
    """Scenarios ``0 .. n-1`` of seed ``seed`` (``cert``: a loaded certificate or a :class:`StudySetup`).

    ``horizon_s`` as in :func:`study_setup`: a setup keeps its own horizon
    unless one is given.

    Raises
    ------
    MonteCarloError
        ``n <= 0``, a negative or non-integer seed, no certificate.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n <= 0:
        raise MonteCarloError(f"number of samples must be a positive integer, got {n!r}")
    if cert is None:
        raise MonteCarloError("a certificate (or a StudySetup) is required")
    setup = study_setup(cert, ranges, horizon_s=horizon_s)
    return [draw_scenario(i, seed, ranges, setup) for i in range(int(n))]


# =============================================================================== the certificate's own box

#: Keys of a certificate's ``cascade.box``: factors on the vehicle's nominal values, as :class:`ScenarioRanges`.
BOX_KEYS: tuple[str, ...] = ("mass_factor", "inertia_factor", "attitude_gain_factor", "tau_motor_factor")


def certificate_rate_hz(cert: Mapping[str, Any]) -> float:
    """The control rate a certificate states [Hz]: ``cascade.rate_hz``, else ``margins.rate_hz``, else the default.

    The default is :data:`nniquad.config.CONTROL_RATE_HZ` (a certificate that states no rate).
    """
    for section in ("cascade", "margins"):
        sec = cert.get(section)
        if isinstance(sec, Mapping):
            v = _cert_float(sec.get("rate_hz"))
            if v is not None:
                return v
    return float(CONTROL_RATE_HZ)


def within_certificate_ranges(cert: Mapping[str, Any]) -> tuple[ScenarioRanges, float, float]:
    """Scenario ranges that stay inside what a certificate's ``cascade`` section certifies.

    The mass, inertia (each axis), attitude-gain and motor time-constant
    factors are drawn from ``cascade.box``; the initial displacement from the
    disk of radius ``cascade.region_of_attraction.max_displacement_m``, a fraction
    :data:`nniquad.config.MC_WITHIN_RIM_FRACTION` of them on its rim; the
    rate is ``cascade.rate_hz`` (the NNI controller in discrete time).  Noise
    and wind are off: the certificate covers neither.  The capped ``Jz``
    (``min(f_z Jz, f_x Jx + f_y Jy)``) stays inside the box too, since
    ``Jx + Jy >= Jz``.

    Parameters
    ----------
    cert
        A loaded certificate (a mapping).

    Returns
    -------
    ranges : ScenarioRanges
        The box, no noise, no wind, ``noise_rate_hz`` the certified rate,
        ``max_displacement_m`` the certified radius, ``rim_fraction``
        :data:`nniquad.config.MC_WITHIN_RIM_FRACTION`.
    region_m : float
        The certified initial-displacement radius [m] (pass it to :func:`study_setup`).
    rate_hz : float
        The certified rate [Hz].

    Raises
    ------
    MonteCarloError
        The certificate has no ``cascade`` section (it certifies no box), or
        the section lacks a usable box, region or rate.
    """
    cas = cert.get("cascade") if isinstance(cert, Mapping) else None
    if not isinstance(cas, Mapping):
        raise MonteCarloError("the certificate certifies no parameter box (it has no 'cascade' section; schema "
                              f"{cert.get('schema_version', '?') if isinstance(cert, Mapping) else '?'}): "
                              "--within-certificate needs a cascade certificate")
    box = cas.get("box")
    if not isinstance(box, Mapping):
        raise MonteCarloError("the certificate's cascade section has no 'box'")
    missing = [k for k in BOX_KEYS if k not in box]
    if missing:
        raise MonteCarloError(f"the certificate's cascade box lacks '{missing[0]}'")
    factors = {k: _pair(f"cascade.box.{k}", box[k], positive=True) for k in BOX_KEYS}
    roa = cas.get("region_of_attraction")
    region = _cert_float(roa.get("max_displacement_m")) if isinstance(roa, Mapping) else None
    if region is None:
        raise MonteCarloError("the certificate's cascade section states no region_of_attraction.max_displacement_m")
    rate = _cert_float(cas.get("rate_hz"))
    if rate is None:
        raise MonteCarloError("the certificate's cascade section states no rate_hz")
    ranges = ScenarioRanges(**factors, tau_motor_s=None, noise_sigma_m=(0.0, 0.0), noise_rate_hz=rate,
                            wind_weight_fraction=(0.0, 0.0), wind_N=None, max_displacement_m=region,
                            rim_fraction=MC_WITHIN_RIM_FRACTION)
    return ranges, region, rate
