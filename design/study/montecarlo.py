"""Monte Carlo robustness studies of a certified gain set, on one machine or a Dask cluster.

A certificate says what the theory guarantees for the *nominal* vehicle.  This
module asks what happens to the ``full`` closed loop (:mod:`nniquad.sim.simulate`:
12-state vehicle, inner loops, rotor saturation) when the things the model
leaves out are drawn at random:

=====================  =====================================  ==========================
perturbation           default range (:class:`ScenarioRanges`)  where it enters
=====================  =====================================  ==========================
mass                   nominal × U[0.8, 1.2]                   true plant ``m``; the
                                                               controller keeps ``m̂``
inertia                each axis × U[0.8, 1.2]                 true ``Jx, Jy, Jz``
                       (``Jz`` capped at ``Jx + Jy``)
attitude-loop gain     × U[0.7, 1.3]                           ``att_scale`` (torques)
motor time constant    U[5, 40] ms, lag on                     ``tau_motor``
position noise σ       U[0, 2] cm, sampled and held at 100 Hz  exogenous input
wind force             magnitude U[0, 0.3] N,                  ``wind_x, wind_y``
                       direction U[0°, 360°)
initial displacement   uniform over the disk of radius         ``xi0``, at rest
                       ``min(certified region, 5 m)``
=====================  =====================================  ==========================

Why these ranges: a battery swap or a camera changes a 0.5 kg vehicle's mass
by 10-20 %; inertias measured by a pendulum test or taken from CAD are good to
10-20 %; the attitude-loop gain error lumps the errors of the thrust and drag
coefficients and of the inertia estimate (±30 %); small brushless motors with
light propellers have time constants of 10-50 ms (the vehicle file assumes
20 ms; below 5 ms the lag is negligible next to the 25 rad/s attitude loop);
2 cm is the noise of RTK-GNSS or UWB positioning (motion capture is below
1 mm); 0.3 N is the drag of a 5 m/s breeze on a drag area C_d A ≈ 0.02 m²
(6 % of the paper vehicle's weight).

Success
-------
A scenario succeeds when it *settled* and never *diverged*:

* **settled** -- the horizontal position ends, and stays from its settling time
  on, inside the band of 2 % of the certificate's nominal initial distance
  ``‖xi0_m‖`` (0.05 m for (2, -1.5) m) around the **static equilibrium** of
  that scenario, :func:`nniquad.analysis.metrics.settling_time_batch` (last exit,
  interpolated).  The paper's controller has no integral action: a constant
  wind force ``F`` moves the equilibrium to ``ξ_eq = F / (m̂ k_p − 1/δ)`` per
  axis (exact for the full model with its altitude integrator), and the offset
  is reported separately (``offset_m``).
* **diverged** -- a non-finite state, a horizontal distance beyond
  ``100 · max(‖ξ(0)‖, band)``, or an altitude deviation beyond
  ``altitude_limit_m`` (default 2 m; a vehicle whose thrust cannot carry its
  mass falls and fails here).

Reproducibility
---------------
Scenario ``i`` of a study with seed ``S`` is drawn from its own stream,
``numpy.random.default_rng(SeedSequence(S, spawn_key=(i,)))`` -- the same
stream as ``SeedSequence(S).spawn(n)[i]`` -- so it does not depend on ``n``, on
the batch size or on the number of workers, and can be rerun alone
(``nniquad montecarlo --seed S --rerun i``).  Its noise sequence comes from an
integer seed drawn from that stream.  Results are sorted by index before
they are summarised.

Execution
---------
Scenarios are simulated one per CasADi call (single-threaded), in batches: the
unit of work of a local :class:`concurrent.futures.ProcessPoolExecutor`
(``spawn`` start method, one process per core, workers ignore Ctrl-C) or of a
Dask distributed cluster (:func:`connect_scheduler`, which fails fast on a
bad or unreachable address).  A scenario holds the GIL while CasADi runs, so
Dask workers should be processes with one thread each.  On
``KeyboardInterrupt`` the pending batches are cancelled and the finished ones
are returned, marked partial.
"""

from __future__ import annotations

import math
import os
import signal
import time
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nniquad.errors import NniquadError
from nniquad.analysis.metrics import DEFAULT_BAND_FRACTION, settling_time_batch, tilt_deg
from nniquad.sim.simulate import STATE_NAMES, SimOptions, SimParams, exogenous_inputs, initial_state, run_batch

__all__ = [
    "MonteCarloError",
    "ScenarioRanges",
    "DEFAULT_RANGES",
    "StudySetup",
    "Scenario",
    "ScenarioResult",
    "StudyRun",
    "Summary",
    "study_setup",
    "study_setup_from",
    "draw_scenario",
    "draw_scenarios",
    "run_scenarios",
    "make_batches",
    "auto_batch_size",
    "run_study",
    "connect_scheduler",
    "close_client",
    "cluster_threads",
    "summarize",
    "wilson_interval",
    "quantile_ci",
    "DEFAULT_HORIZON_S",
    "CONNECT_TIMEOUT_S",
]

#: Default simulated time of a scenario [s].
DEFAULT_HORIZON_S = 20.0
#: Time allowed to reach a Dask scheduler [s].
CONNECT_TIMEOUT_S = 5.0

_IX = {n: i for i, n in enumerate(STATE_NAMES["full"])}


class MonteCarloError(NniquadError):
    """A Monte Carlo option is invalid, or the cluster cannot be reached or failed."""


# =============================================================================== ranges


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
    tau_motor_s
        Motor time constant [s] (default 0.005-0.040; at least ``2 dt``).
    noise_sigma_m
        Standard deviation of the position noise [m] (default 0-0.02).
    noise_rate_hz
        Position-sensor sample rate [Hz] (default 100; the measurement is sampled and held).
    wind_N
        Magnitude of the constant horizontal wind force [N] (default 0-0.3),
        direction uniform.
    max_displacement_m
        Cap on the initial displacement radius [m] (default 5); the radius is
        ``min(certified region, cap)``.
    altitude_limit_m
        An altitude deviation beyond this [m] counts as divergence (default 2).
    """

    mass_factor: tuple[float, float] = (0.8, 1.2)
    inertia_factor: tuple[float, float] = (0.8, 1.2)
    attitude_gain_factor: tuple[float, float] = (0.7, 1.3)
    tau_motor_s: tuple[float, float] = (0.005, 0.040)
    noise_sigma_m: tuple[float, float] = (0.0, 0.02)
    noise_rate_hz: float = 100.0
    wind_N: tuple[float, float] = (0.0, 0.3)
    max_displacement_m: float = 5.0
    altitude_limit_m: float = 2.0

    def __post_init__(self) -> None:
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        set_("mass_factor", _pair("mass factor range", self.mass_factor, positive=True))
        set_("inertia_factor", _pair("inertia factor range", self.inertia_factor, positive=True))
        set_("attitude_gain_factor", _pair("attitude-gain factor range", self.attitude_gain_factor, positive=True))
        set_("tau_motor_s", _pair("motor time-constant range", self.tau_motor_s, lo=0.002))
        set_("noise_sigma_m", _pair("noise sigma range", self.noise_sigma_m, lo=0.0))
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
        Nominal :class:`nniquad.sim.simulate.SimParams` vector (certificate vehicle,
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
    """

    base_params: tuple[float, ...]
    xi0_nominal_m: tuple[float, float]
    region_m: float
    band_m: float
    horizon_s: float = DEFAULT_HORIZON_S
    dt_s: float = 1e-3
    output_dt_s: float = 0.01
    label: str = ""

    @property
    def base(self) -> SimParams:
        return SimParams.from_vector(self.base_params)

    def to_json(self) -> dict[str, Any]:
        b = self.base
        return {
            "certificate": self.label,
            "gains": {"kp": b.kpx, "kpy": b.kpy, "Gamma": b.Gamma, "delta": b.delta},
            "nominal_mass_kg": b.m_nom,
            "tilt_limit_deg": math.degrees(b.tilt_limit),
            "xi0_nominal_m": list(self.xi0_nominal_m),
            "displacement_radius_m": self.region_m,
            "settling_band_m": self.band_m,
            "horizon_s": self.horizon_s,
            "dt_s": self.dt_s,
            "output_dt_s": self.output_dt_s,
        }


def _cert_float(value: Any) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) and v > 0 else None


def study_setup_from(vehicle: Any, gains: Any, *, inner: Any = None, tilt_limit_deg: float = 30.0,
                     xi0_m: Sequence[float] = (2.0, -1.5), region_m: float | None = None,
                     ranges: ScenarioRanges = DEFAULT_RANGES, horizon_s: float = DEFAULT_HORIZON_S,
                     label: str = "") -> StudySetup:
    """The shared part of a study from a vehicle, a gain set and inner-loop gains (no certificate).

    ``region_m`` (default ``‖xi0_m‖``) is capped at ``ranges.max_displacement_m``.
    """
    from nniquad.sim.simulate import to_gains

    h = _cert_float(horizon_s)
    if h is None:
        raise MonteCarloError(f"horizon must be a positive number of seconds, got {horizon_s!r}")
    try:
        xi0 = tuple(float(v) for v in xi0_m)
        if len(xi0) != 2 or not all(math.isfinite(v) for v in xi0) or math.hypot(*xi0) <= 0:
            raise ValueError
    except (TypeError, ValueError):
        raise MonteCarloError(f"initial position xi0_m must be a non-zero pair of numbers, got {xi0_m!r}") from None
    opts: dict[str, Any] = {"model": "full", "horizon_s": h, "motor_lag": True, "sample_hold": True,
                            "noise_rate_hz": ranges.noise_rate_hz, "tilt_limit_deg": tilt_limit_deg}
    if inner is not None:
        opts["inner"] = inner
    options = SimOptions(**opts)
    base = SimParams.from_options(vehicle, to_gains(gains), options)
    region = _cert_float(region_m)
    if region is None:
        region = math.hypot(*xi0)
    return StudySetup(
        base_params=tuple(float(v) for v in base.vector()),
        xi0_nominal_m=(xi0[0], xi0[1]),
        region_m=min(region, ranges.max_displacement_m),
        band_m=DEFAULT_BAND_FRACTION * math.hypot(*xi0),
        horizon_s=h,
        dt_s=options.dt_s,
        output_dt_s=options.output_dt_s,
        label=label,
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
                horizon_s: float | None = None) -> StudySetup:
    """The shared part of a study from a loaded certificate (:func:`nniquad.certificates.certificate.load_certificate`).

    ``horizon_s`` defaults to :data:`DEFAULT_HORIZON_S` for a certificate.  A
    :class:`StudySetup` is returned as it is (its own horizon and displacement
    radius; ``ranges`` is not applied again), with ``horizon_s`` replaced only
    when one is given.

    Gains, vehicle and inner-loop gains come from
    :func:`nniquad.certificates.certificate.certificate_gains`, ``certificate_vehicle`` and
    ``certificate_inner_loop``; the displacement radius from
    ``region_of_attraction.max_displacement_m`` (the nominal ``‖xi0_m‖`` when the
    certificate states no region), capped at ``ranges.max_displacement_m``.

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
    return study_setup_from(
        C.certificate_vehicle(cert), C.certificate_gains(cert), inner=C.certificate_inner_loop(cert),
        tilt_limit_deg=30.0 if tilt is None else tilt, xi0_m=cert.get("xi0_m", (2.0, -1.5)),
        region_m=roa.get("max_displacement_m") if isinstance(roa, Mapping) else None,
        ranges=ranges, horizon_s=DEFAULT_HORIZON_S if horizon_s is None else horizon_s,
        label=_certificate_label(cert),
    )


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
        The perturbed :class:`nniquad.sim.simulate.SimParams` vector.
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

    @property
    def sim_params(self) -> SimParams:
        return SimParams.from_vector(self.params)

    def with_params(self, **changes: float) -> "Scenario":
        """Copy with some plant parameters changed (e.g. ``m=3.0`` for a vehicle that cannot hover)."""
        return replace(self, params=tuple(float(v) for v in self.sim_params.with_(**changes).vector()))

    def equilibrium_m(self) -> tuple[float, float]:
        """Static equilibrium under the constant wind, ``F / (m̂ k_p − 1/δ)`` per axis (origin if none)."""
        p = self.sim_params
        out = []
        for force, kp in ((p.wind_x, p.kpx), (p.wind_y, p.kpy)):
            stiffness = p.m_nom * kp - 1.0 / p.delta
            out.append(force / stiffness if stiffness > 0 else 0.0)
        return (out[0], out[1])

    def describe(self) -> dict[str, Any]:
        """The drawn quantities with units (JSON ready)."""
        p = self.sim_params
        wind = math.hypot(p.wind_x, p.wind_y)
        return {
            "mass_kg": p.m,
            **{f"{k}_factor": v for k, v in self.factors},
            "Jx_kg_m2": p.Jx, "Jy_kg_m2": p.Jy, "Jz_kg_m2": p.Jz,
            "attitude_gain": p.att_scale,
            "tau_motor_s": p.tau_motor,
            "thrust_to_weight": 4 * p.b * p.omega_max**2 / (p.m * p.g),
            "noise_sigma_m": self.noise_sigma_m,
            "wind_N": [p.wind_x, p.wind_y],
            "wind_magnitude_N": wind,
            "wind_direction_deg": math.degrees(math.atan2(p.wind_y, p.wind_x)) % 360.0 if wind > 0 else 0.0,
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
    wind direction, displacement radius (``R √u``, uniform over the disk),
    displacement direction, noise seed.
    """
    seed = _check_seed(seed)
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
        raise MonteCarloError(f"scenario index must be a non-negative integer, got {index!r}")
    if 2 * setup.dt_s > ranges.tau_motor_s[0] + 1e-15:
        raise MonteCarloError(f"motor time constant must be at least 2 dt = {2 * setup.dt_s:g} s for RK4")
    rng = _stream(seed, int(index))
    u = lambda r: float(rng.uniform(r[0], r[1]))  # noqa: E731
    base = setup.base
    f_m = u(ranges.mass_factor)
    f_J = [u(ranges.inertia_factor) for _ in range(3)]
    f_att = u(ranges.attitude_gain_factor)
    tau = u(ranges.tau_motor_s)
    sigma = u(ranges.noise_sigma_m)
    wind = u(ranges.wind_N)
    wdir = float(rng.uniform(0.0, 2 * math.pi))
    radius = setup.region_m * math.sqrt(float(rng.uniform(0.0, 1.0)))
    rdir = float(rng.uniform(0.0, 2 * math.pi))
    noise_seed = int(rng.integers(0, 2**63 - 1))
    Jx, Jy = base.Jx * f_J[0], base.Jy * f_J[1]
    Jz = min(base.Jz * f_J[2], Jx + Jy)
    params = base.with_(
        m=base.m * f_m, Jx=Jx, Jy=Jy, Jz=Jz, att_scale=base.att_scale * f_att, tau_motor=tau, motor_lag=1.0,
        wind_x=wind * math.cos(wdir), wind_y=wind * math.sin(wdir), sample_hold=1.0, dt=setup.dt_s,
    )
    return Scenario(
        index=int(index), study_seed=seed, params=tuple(float(v) for v in params.vector()),
        xi0_m=(radius * math.cos(rdir), radius * math.sin(rdir)),
        noise_sigma_m=sigma, noise_rate_hz=ranges.noise_rate_hz, noise_seed=noise_seed,
        horizon_s=setup.horizon_s, dt_s=setup.dt_s, output_dt_s=setup.output_dt_s,
        band_m=setup.band_m, altitude_limit_m=ranges.altitude_limit_m,
        factors=(("mass", f_m), ("Jx", f_J[0]), ("Jy", f_J[1]), ("Jz", f_J[2]), ("attitude_gain", f_att)),
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


# =============================================================================== running one batch


@dataclass(frozen=True)
class ScenarioResult:
    """Outcome of one scenario.

    Attributes
    ----------
    index, study_seed
        Which scenario (rerun with ``--seed study_seed --rerun index``).
    success
        Settled and never diverged.
    failure
        ``None``, ``"diverged"``, ``"altitude lost"``, ``"not settled"`` or ``"error: ..."``.
    settling_s
        Settling time around the equilibrium [s]; ``None`` if not settled.
    peak_tilt_deg
        Largest total tilt [deg] (``None`` if non-finite).
    offset_m
        Distance of the wind equilibrium from the origin [m].
    final_error_m
        Distance from the equilibrium at the end of the run [m].
    max_altitude_dev_m
        Largest altitude deviation [m].
    scenario
        The drawn quantities (:meth:`Scenario.describe`).
    """

    index: int
    study_seed: int
    success: bool
    failure: str | None
    settling_s: float | None
    peak_tilt_deg: float | None
    offset_m: float
    final_error_m: float | None
    max_altitude_dev_m: float | None
    scenario: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None
        return d

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> "ScenarioResult":
        return cls(**{f.name: data.get(f.name) for f in fields(cls)})


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _run_one(s: Scenario) -> ScenarioResult:
    p = s.sim_params
    eq = s.equilibrium_m()
    desc = s.describe()
    try:
        opts = SimOptions(model="full", horizon_s=s.horizon_s, dt_s=s.dt_s, output_dt_s=s.output_dt_s,
                          noise_sigma_m=s.noise_sigma_m, noise_rate_hz=s.noise_rate_hz, sample_hold=True,
                          seed=s.noise_seed, xi0=s.xi0_m)
        x0 = initial_state("full", p, s.xi0_m)
        exo = exogenous_inputs(opts)
        with np.errstate(all="ignore"):
            X, _ = run_batch("full", np.asarray(s.params)[None], x0[None], exo,
                             steps_per_sample=opts.steps_per_sample, n_samples=opts.n_samples)
    except NniquadError as exc:
        return ScenarioResult(s.index, s.study_seed, False, f"error: {exc}", None, None,
                              math.hypot(*eq), None, None, desc)
    X = X[0]
    t = np.arange(X.shape[0]) * s.output_dt_s
    xy = X[:, [_IX["x"], _IX["y"]]]
    with np.errstate(all="ignore"):
        rel = xy - np.asarray(eq)
        d0 = math.hypot(*s.xi0_m)
        limit = 100.0 * max(d0, s.band_m)
        finite = bool(np.all(np.isfinite(X)))
        far = bool(np.any(~(np.hypot(xy[:, 0], xy[:, 1]) <= limit)))
        alt = float(np.max(np.abs(X[:, _IX["z"]])))
        tilt = tilt_deg(X[:, _IX["phi"]], X[:, _IX["theta"]])
        peak_tilt = float(np.max(tilt))
        final = float(np.hypot(*rel[-1]))
    settling = float(settling_time_batch(t, rel[None], DEFAULT_BAND_FRACTION,
                                         s.band_m / DEFAULT_BAND_FRACTION)[0])
    if not finite or far:
        failure = "diverged"
    elif not alt <= s.altitude_limit_m:
        failure = "altitude lost"
    elif not math.isfinite(settling):
        failure = "not settled"
    else:
        failure = None
    return ScenarioResult(
        index=s.index, study_seed=s.study_seed, success=failure is None, failure=failure,
        settling_s=None if failure is not None else settling,
        peak_tilt_deg=_finite_or_none(peak_tilt), offset_m=math.hypot(*eq),
        final_error_m=_finite_or_none(final), max_altitude_dev_m=_finite_or_none(alt), scenario=desc,
    )


def run_scenarios(batch: Sequence[Scenario]) -> list[ScenarioResult]:
    """Simulate a batch of scenarios (the unit of work of the executors).

    A pure function of the scenarios: the same scenario gives the same result
    in any process, batch or order.  Each scenario is one single-threaded
    :func:`nniquad.sim.simulate.run_batch` call with its own noise sequence.
    Simulation errors become failures (``"error: ..."``), never exceptions.
    """
    return [_run_one(s) for s in batch]


# =============================================================================== executors


def auto_batch_size(n: int, workers: int) -> int:
    """About four batches per worker, 1 to 50 scenarios each.

    At ~0.06 s per 20 s scenario, a batch of 50 is ~3 s of work against a
    scheduling cost of a few ms (local pool or Dask).
    """
    return max(1, min(50, math.ceil(n / (4 * max(1, workers)))))


def make_batches(scenarios: Sequence[Scenario], batch_size: int) -> list[list[Scenario]]:
    """Consecutive batches of ``batch_size`` scenarios (the last may be shorter).

    Raises
    ------
    MonteCarloError
        ``batch_size`` is not a positive integer.
    """
    if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
        raise MonteCarloError(f"batch size must be a positive integer, got {batch_size!r}")
    return [list(scenarios[i:i + batch_size]) for i in range(0, len(scenarios), batch_size)]


@dataclass
class StudyRun:
    """Results of :func:`run_study`.

    Attributes
    ----------
    results
        One per finished scenario, sorted by index.
    n_requested
        Number of scenarios asked for.
    partial
        ``True`` when interrupted (only finished batches are in ``results``).
    elapsed_s
        Wall time [s].
    executor
        ``"in-process"``, ``"local process pool"`` or ``"dask tcp://..."``.
    workers, batch_size
        Worker processes (or Dask threads) and scenarios per batch.
    """

    results: list[ScenarioResult]
    n_requested: int
    partial: bool
    elapsed_s: float
    executor: str
    workers: int
    batch_size: int

    @property
    def scenarios_per_s(self) -> float:
        return len(self.results) / self.elapsed_s if self.elapsed_s > 0 else float("nan")


def _ignore_sigint() -> None:  # pool initializer: Ctrl-C is the parent's business
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _first_line(exc: BaseException, limit: int = 120) -> str:
    text = str(exc).strip()
    detail = text.splitlines()[0] if text else type(exc).__name__
    return detail if len(detail) <= limit else detail[: limit - 3] + "..."


def _probe_scheduler(address: str, timeout_s: float) -> Any:
    """Ask the server at ``address`` for its identity over Dask's own protocol (in a fresh event loop)."""
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import connect

    async def identity() -> Any:
        comm = await connect(address, timeout=timeout_s)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    def probe() -> Any:
        return asyncio.run(asyncio.wait_for(identity(), timeout_s))

    # a thread of its own: works even when the caller already runs an event loop (Jupyter)
    with ThreadPoolExecutor(max_workers=1) as ex:
        return ex.submit(probe).result()


def connect_scheduler(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> Any:
    """A ``dask.distributed.Client`` on the running scheduler at ``address``; fails fast and in one line.

    Three steps, each bounded by ``timeout_s``: the address is parsed
    (``tcp://host:port``, ``host:port`` or ``tls://host:port``); a plain TCP
    connection is opened (a refused connection or an unknown host fails at
    once, where Dask itself would retry until its timeout); the server is
    asked for its identity over Dask's protocol (a port that answers but is
    not a Dask scheduler fails here).  Only then is the client created.

    Parameters
    ----------
    address
        Scheduler address, e.g. ``tcp://10.0.0.5:8786``.
    timeout_s
        Time allowed for each step [s].

    Returns
    -------
    distributed.Client
        Not set as the default client; the caller closes it.

    Raises
    ------
    MonteCarloError
        dask.distributed is not installed, the address is malformed, or the
        scheduler cannot be reached in time.
    """
    import socket

    try:
        from distributed import Client
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        raise MonteCarloError("--scheduler needs dask.distributed: pip install 'nniquad[dask]'") from None
    import logging

    for name in ("distributed.comm", "distributed.client", "distributed.core", "distributed.batched"):
        logging.getLogger(name).setLevel(logging.CRITICAL)
    where = f"cannot reach the Dask scheduler at {address}"
    if not isinstance(address, str) or not address.strip():
        raise MonteCarloError(f"scheduler address must look like tcp://host:port, got {address!r}")
    try:
        scheme, loc = parse_address(address.strip(), strict=False)
        host, port = parse_host_port(loc)
    except (TypeError, ValueError) as exc:
        raise MonteCarloError(f"scheduler address must look like tcp://host:port, got {address!r} "
                              f"({_first_line(exc)})") from None
    if scheme not in ("tcp", "tls") or not host:
        raise MonteCarloError(f"scheduler address must look like tcp://host:port, got {address!r}")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except socket.gaierror:
        raise MonteCarloError(f"{where}: unknown host {host!r}") from None
    except (socket.timeout, TimeoutError):
        raise MonteCarloError(f"{where}: no answer within {timeout_s:g} s") from None
    except OSError as exc:
        raise MonteCarloError(f"{where}: {exc.strerror or _first_line(exc)}") from None
    if scheme == "tcp":  # tls needs the caller's security settings: the client checks it below
        try:
            ident = _probe_scheduler(address.strip(), timeout_s)
        except Exception as exc:  # noqa: BLE001 -- timeout, garbage from a non-Dask server, ...
            if isinstance(exc, TimeoutError) or "timed out" in str(exc).lower():
                detail = f"no answer within {timeout_s:g} s"
            else:
                detail = f"the server does not answer as a Dask scheduler ({type(exc).__name__})"
            raise MonteCarloError(f"{where}: {detail}") from None
        if not (isinstance(ident, Mapping) and ident.get("type") == "Scheduler"):
            kind = ident.get("type") if isinstance(ident, Mapping) else type(ident).__name__
            raise MonteCarloError(f"{where}: the server is not a Dask scheduler (it says {kind!r})")
    t0 = time.perf_counter()
    try:
        return Client(address.strip(), timeout=f"{timeout_s:g}s", set_as_default=False)
    except Exception as exc:  # noqa: BLE001 -- OSError, TimeoutError, ...
        detail = _first_line(exc)
        if "timed out" in detail.lower() or time.perf_counter() - t0 >= timeout_s:
            detail = f"no answer within {timeout_s:g} s"
        raise MonteCarloError(f"{where}: {detail}") from None


def close_client(client: Any) -> None:
    """Close a client from :func:`connect_scheduler` quietly (the cluster itself keeps running)."""
    try:
        client.close(timeout=2)
    except Exception:  # noqa: BLE001 -- closing is best effort
        pass


def cluster_threads(client: Any) -> int:
    """Worker threads of the cluster behind ``client`` (0 when no worker has joined yet)."""
    try:
        return int(sum(client.nthreads().values()))
    except Exception:  # noqa: BLE001
        return 0


def run_study(
    scenarios: Sequence[Scenario],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    client: Any = None,
    batch_size: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
) -> StudyRun:
    """Run the scenarios in batches and collect the results, sorted by index.

    Parameters
    ----------
    scenarios
        From :func:`draw_scenarios`.
    workers
        Local worker processes (default ``os.cpu_count()``); 1 runs in this
        process.  Ignored with a scheduler.
    scheduler
        Address of a running Dask scheduler (``tcp://host:port``).
    client
        An existing ``dask.distributed.Client`` (instead of ``scheduler``).
    batch_size
        Scenarios per batch (default :func:`auto_batch_size`).
    progress
        Called as ``progress(done, total)`` after each finished batch.
    connect_timeout_s
        Time allowed to reach the scheduler.

    Returns
    -------
    StudyRun
        ``partial`` is set when interrupted by ``KeyboardInterrupt``; the
        finished batches are kept and the pending ones cancelled.

    Raises
    ------
    MonteCarloError
        Bad options, an unreachable scheduler, a failed worker.
    """
    scenarios = list(scenarios)
    total = len(scenarios)
    if total == 0:
        raise MonteCarloError("no scenarios to run")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                                or workers < 1):
        raise MonteCarloError(f"number of workers must be a positive integer, got {workers!r}")
    if batch_size is not None:
        make_batches(scenarios[:1], batch_size)  # validates before any connection is made
    t0 = time.perf_counter()
    own_client = False
    if client is None and scheduler:
        client = connect_scheduler(scheduler, connect_timeout_s)
        own_client = True
    collected: list[ScenarioResult] = []
    partial = False
    done = 0

    def _add(res: list[ScenarioResult]) -> None:
        nonlocal done
        collected.extend(res)
        done += len(res)
        if progress is not None:
            progress(done, total)

    try:
        if client is not None:
            n_workers = max(1, cluster_threads(client))
            executor = f"dask {getattr(client.scheduler, 'address', scheduler)}"
        else:
            n_workers = int(workers or os.cpu_count() or 1)
            executor = "in-process" if n_workers == 1 else "local process pool"
        bs = auto_batch_size(total, n_workers) if batch_size is None else int(batch_size)
        batches = make_batches(scenarios, bs)
        if client is not None:
            partial = _run_dask(client, batches, _add)
        elif n_workers == 1:
            try:
                for b in batches:
                    _add(run_scenarios(b))
            except KeyboardInterrupt:
                partial = True
        else:
            partial = _run_pool(n_workers, batches, _add)
    finally:
        if own_client:
            close_client(client)
    collected.sort(key=lambda r: r.index)
    return StudyRun(collected, total, partial, time.perf_counter() - t0, executor, n_workers, bs)


def _run_pool(n_workers: int, batches: list[list[Scenario]], add: Callable[[list[ScenarioResult]], None]) -> bool:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    pool = ProcessPoolExecutor(max_workers=min(n_workers, len(batches)),
                               mp_context=multiprocessing.get_context("spawn"),
                               initializer=_ignore_sigint)
    futures = []
    taken: set[int] = set()
    interrupted = False
    try:
        futures = [pool.submit(run_scenarios, b) for b in batches]
        for fut in as_completed(futures):
            taken.add(id(fut))
            add(fut.result())
    except KeyboardInterrupt:
        interrupted = True
        for fut in futures:  # finished but not yet collected: keep them
            if id(fut) not in taken and fut.done() and not fut.cancelled() and fut.exception() is None:
                try:
                    add(fut.result())
                except KeyboardInterrupt:
                    pass
    except BrokenProcessPool as exc:
        raise MonteCarloError(f"a local worker process died ({exc})") from None
    finally:
        if interrupted:
            procs = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=False, cancel_futures=True)
            for proc in procs:  # stop the running batches now (their results would be discarded)
                try:
                    proc.terminate()
                except Exception:  # noqa: BLE001
                    pass
            for proc in procs:
                proc.join(timeout=5)
        else:
            pool.shutdown(wait=True, cancel_futures=True)
    return interrupted


def _run_dask(client: Any, batches: list[list[Scenario]], add: Callable[[list[ScenarioResult]], None]) -> bool:
    from distributed import as_completed

    futures = client.map(run_scenarios, batches, pure=False)
    taken: set[str] = set()
    try:
        for fut in as_completed(futures, loop=client.loop):  # not the default client: name its loop
            taken.add(fut.key)
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001
                client.cancel(futures)
                detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                raise MonteCarloError(f"a Dask worker failed: {type(exc).__name__}: {detail} "
                                      "(is nniquad installed on every worker?)") from None
            add(res)
    except KeyboardInterrupt:
        for fut in futures:
            if fut.key not in taken and fut.status == "finished":
                try:
                    add(fut.result(timeout=1))
                except BaseException:  # noqa: BLE001 -- keep what we have
                    pass
        try:
            client.cancel(futures)
        except Exception:  # noqa: BLE001
            pass
        return True
    return False


# =============================================================================== statistics


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
        settled), then the longest settling times.
    partial
        Computed from an interrupted study.
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
        for k in ("p50", "p95", "p99"):
            lines.append(f"{'peak tilt ' + k:<24} {ci(self.peak_tilt[k], 'deg')}")
        lines.append(f"{'peak tilt max':<24} {s(self.peak_tilt['max'], 'deg'):>12}   "
                     f"(scenario {self.peak_tilt['max_index']})")
        lines.append(f"{'max wind offset':<24} {s(self.max_offset_m, 'm'):>12}")
        lines.append(f"{'max altitude deviation':<24} {s(self.max_altitude_dev_m, 'm'):>12}")
        if self.worst:
            lines.append("worst cases (failures first, then the longest settling):")
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
    tilts = np.array([math.inf if r.peak_tilt_deg is None else r.peak_tilt_deg for r in rs])
    finite_t = tilts[np.isfinite(tilts)]
    peak = {f"p{int(100 * q)}": quantile_ci(tilts, q) for q in (0.5, 0.95, 0.99)}
    imax = int(np.argmax(tilts))
    peak.update(mean=float(np.mean(finite_t)) if finite_t.size else math.nan, max=float(tilts[imax]),
                max_index=rs[imax].index)

    def badness(r: ScenarioResult) -> tuple:
        if r.failure:
            return (0, _FAILURE_RANK.get(r.failure, -1), r.index)
        return (1, -(r.settling_s or 0.0), r.index)

    worst = sorted(rs, key=badness)[: max(0, n_worst)]
    alts = [r.max_altitude_dev_m for r in rs if r.max_altitude_dev_m is not None]
    return Summary(
        n=n, n_success=k, success_rate=k / n, success_ci=wilson_interval(k, n), failures=failures,
        settling={f"p{int(100 * q)}": quantile_ci(settle, q) for q in (0.5, 0.95, 0.99)},
        peak_tilt=peak, max_offset_m=max(r.offset_m for r in rs),
        max_altitude_dev_m=max(alts) if alts else math.nan, worst=worst, partial=partial,
    )
