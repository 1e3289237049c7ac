"""Options of a simulation run (:class:`SimOptions`), validated on construction.

The controller law is not an option: it is the type of the gain block given to
:func:`nniquad.sim.simulate` (:mod:`nniquad.laws`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from nniquad.config import DT_S, OUTPUT_DT_S, TILT_LIMIT_DEG, XI0_M
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.control.references import Reference
from nniquad.errors import SimulationError
from nniquad.validate import finite_number

__all__ = ["MODELS", "CONTROLLER_SAMPLING", "SimOptions", "check_model", "check_rate_hz", "check_delay_samples"]

#: Models of the closed loop (:mod:`nniquad.sim.models`).
MODELS: tuple[str, ...] = ("linear", "reduced", "full")

#: How the horizontal controller sees the position (:attr:`SimOptions.controller_sampling`):
#: ``"continuous"`` measurement and controller; ``"held"`` measurement sampled and held at
#: ``noise_rate_hz``, controller state integrated continuously on the held value; ``"discrete"``
#: measurement sampled and the law run in discrete time at that rate (exact ZOH equivalent of its
#: state equation: :class:`nniquad.control.discrete.DiscreteNNI` for NNI; the PD filter likewise; the true
#: velocity of ``pd_velocity`` sampled with the position), its command held over the period.
CONTROLLER_SAMPLING: tuple[str, ...] = ("continuous", "held", "discrete")


def check_model(model: str) -> str:
    """``model`` if it is one of :data:`MODELS`, else :class:`SimulationError`."""
    if not isinstance(model, str) or model not in MODELS:
        raise SimulationError(f"unknown model {model!r} (choose one of {', '.join(MODELS)})")
    return model


def _whole_rates(dt_s: float) -> list[str]:
    """A few rates whose period is a whole number of steps ``dt_s`` (for error messages)."""
    return [f"{1.0 / (n * dt_s):g}" for n in (2, 4, 5, 8, 10, 20)]


def check_rate_hz(rate_hz: Any, dt_s: float = DT_S, *, discrete: bool = True, option: str = "--rate",
                  error: type[Exception] = SimulationError) -> float:
    """A control / sensor rate [Hz] the integrator can represent, else a one-line ``error``.

    Parameters
    ----------
    rate_hz
        The rate.
    dt_s
        The RK4 step [s]: at most one sample per step (``rate <= 1/dt``).
    discrete
        The discrete controller runs at this rate: its period must then be a
        whole number of steps (the sample instants fall on steps; otherwise the
        period would alternate between two step counts).
    option
        Name of the option in the message.
    error
        Exception class raised.

    Returns
    -------
    float
    """
    if isinstance(rate_hz, bool):
        raise error(f"{option}: sample rate must be a finite positive number of Hz, got {rate_hz!r}")
    try:
        rate = float(rate_hz)
    except (TypeError, ValueError):
        raise error(f"{option}: sample rate must be a finite positive number of Hz, got {rate_hz!r}") from None
    if not math.isfinite(rate) or rate <= 0:
        raise error(f"{option}: sample rate must be positive and finite, got {rate_hz!r}")
    if rate * dt_s > 1 + 1e-9:
        raise error(f"{option}: sample rate {rate:g} Hz exceeds the integration rate 1/dt = {1 / dt_s:g} Hz")
    n = 1.0 / (rate * dt_s)
    if discrete and abs(n - round(n)) > 1e-6 * n:
        raise error(f"{option}: the discrete controller needs a sample period 1/{rate:g} Hz that is a whole multiple "
                    f"of the time step {dt_s:g} s (e.g. {', '.join(_whole_rates(dt_s))} Hz)")
    return rate


def check_delay_samples(value: Any, *, sampled: bool = True, error: type[Exception] = SimulationError) -> int:
    """A measurement delay in samples: an integer ``>= 0``, and ``0`` unless the measurement is sampled.

    Parameters
    ----------
    value
        The delay [samples].
    sampled
        Whether the run samples the measurement (a delay of whole samples needs samples).
    error
        Exception class raised (one line).
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise error(f"delay_samples must be a whole number of samples >= 0, got {value!r}")
    if value and not sampled:
        raise error(f"a delay of {int(value)} samples needs a sampled run (controller sampling held or discrete), "
                    "not a continuous-time one")
    return int(value)


def _finite(name: str, value: Any, *, positive: bool = False, nonneg: bool = False) -> float:
    return finite_number(name, value, error=SimulationError, positive=positive, nonneg=nonneg)


@dataclass(frozen=True)
class SimOptions:
    """Options of one simulation (validated on construction; errors are :class:`SimulationError`).

    Attributes
    ----------
    model
        ``"linear"``, ``"reduced"`` or ``"full"``.
    horizon_s
        Simulated duration [s] (rounded up to a whole output sample).
    dt_s
        RK4 step [s] (default :data:`nniquad.config.DT_S`, 1 ms).
    output_dt_s
        Output sample period [s]; a whole multiple of ``dt_s`` (default :data:`nniquad.config.OUTPUT_DT_S`, 10 ms).
    tilt_limit_deg
        Tilt limit [deg] of ``reduced`` and ``full`` (default :data:`nniquad.config.TILT_LIMIT_DEG`), in (0, 90).
    xi0
        Initial horizontal position [m] (vehicle at rest, level, ψ = 0, z = 0; default
        :data:`nniquad.config.XI0_M`).
    zc0
        Added to the first controller state of each axis at the start (default 0).  The NNI law starts at
        zero, so this is its initial state ``z(0)``; the other laws start at their take-over state for the
        measured position (:func:`nniquad.sim.runner.initial_state`).
    noise_sigma_m
        Standard deviation of the position noise [m] (≥ 0).
    noise_rate_hz
        Position-sensor sample rate [Hz] (> 0, at most ``1/dt_s``); with
        ``controller_sampling="discrete"`` also the control rate, and then
        ``1/noise_rate_hz`` must be a whole multiple of ``dt_s``.
    sample_hold
        Position measurement sampled at ``noise_rate_hz`` and held; ``None``
        (default) means sampled iff ``noise_sigma_m > 0`` (or iff
        ``controller_sampling`` is ``"held"`` or ``"discrete"`` when that is given).
    controller_sampling
        ``"continuous"``, ``"held"`` or ``"discrete"`` (:data:`CONTROLLER_SAMPLING`);
        ``None`` (default) keeps the behaviour of ``sample_hold``: ``"held"`` when
        the measurement is sampled, else ``"continuous"``.  ``"discrete"`` runs the
        NNI law as ``z_{k+1} = e^{-ΓδT} z_k + (1 - e^{-ΓδT})/δ ξ_k``,
        ``a_k = -k_p ξ_k + z_k/m̂``, ``T = 1/noise_rate_hz``, ``a_k`` held over
        ``[kT, (k+1)T)``, the first sample at ``t = 0`` (``z_0 = zc0``); ``pd_filtered``
        likewise with ``d_{k+1} = e^{-T/τ_f} d_k + (1 - e^{-T/τ_f}) ξ_k``, and
        ``pd_velocity`` with the true velocity sampled with the position.
    seed
        Seed of the noise and gust sequences (``numpy.random.default_rng``).
    wind_N
        Constant horizontal wind force (north, east) [N].
    gust_N
        Standard deviation of the gust force per axis [N] (≥ 0).
    gust_tau_s
        Correlation time of the gust (first-order Gauss-Markov) [s].
    motor_lag
        First-order rotor-speed lag (``full`` only).
    tau_motor_s
        Motor time constant [s]; ``None`` takes the vehicle's.
    true_mass_kg
        Mass of the plant [kg]; ``None`` means the vehicle's (= the controller's).
    inner
        Gains of the inner loops (``full``).
    reference
        The reference ``ξ_d(t)`` the law follows (:mod:`nniquad.control.references`); ``None``: the origin.
    feedforward
        Add the reference's acceleration ``ξ̈_d`` to the command before the tilt limit (needs a reference).
    feedforward_lead_s
        Read the feedforward this much ahead, ``a_ff(t) = ξ̈_d(t + lead)`` [s] (default 0): the inner loops realise
        the command late (about ``2 ζ_a/ω_a`` for the attitude loop, plus half a sample period for the hold), and
        the reference's future is known, so reading it that much ahead cancels most of the lag.  Nothing measured.
    v0
        Initial horizontal velocity [m/s] (a start from motion; the law's state is its take-over state for
        the error ``xi0 - ξ_d(0)``, :mod:`nniquad.laws.base`, "Reference and feedforward").
    delay_samples
        Measurement delay [samples] (≥ 0, sampled runs only): the position (noise and reference error included)
        reaches the law this many sample periods ``1/noise_rate_hz`` late, through a delay line of that many
        samples per axis (:func:`nniquad.sim.models.step_function`); the line starts full of the start
        measurement (the vehicle sat at ``xi0`` before take-over).
    """

    model: str = "full"
    horizon_s: float = 60.0
    dt_s: float = DT_S
    output_dt_s: float = OUTPUT_DT_S
    tilt_limit_deg: float = TILT_LIMIT_DEG
    xi0: tuple[float, float] = XI0_M
    zc0: tuple[float, float] = (0.0, 0.0)
    noise_sigma_m: float = 0.0
    noise_rate_hz: float = 100.0
    sample_hold: bool | None = None
    controller_sampling: str | None = None
    seed: int = 0
    wind_N: tuple[float, float] = (0.0, 0.0)
    gust_N: float = 0.0
    gust_tau_s: float = 1.0
    motor_lag: bool = False
    tau_motor_s: float | None = None
    true_mass_kg: float | None = None
    inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS
    reference: Reference | None = None
    feedforward: bool = False
    feedforward_lead_s: float = 0.0
    v0: tuple[float, float] = (0.0, 0.0)
    delay_samples: int = 0

    def __post_init__(self) -> None:
        check_model(self.model)
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        set_("horizon_s", _finite("horizon", self.horizon_s, positive=True))
        set_("dt_s", _finite("time step dt", self.dt_s, positive=True))
        set_("output_dt_s", _finite("output sample period", self.output_dt_s, positive=True))
        k = self.output_dt_s / self.dt_s
        if k < 1 - 1e-9 or abs(k - round(k)) > 1e-6 * k:
            raise SimulationError(
                f"output sample period {self.output_dt_s:g} s must be a whole multiple of the time step {self.dt_s:g} s"
            )
        tl = _finite("tilt limit", self.tilt_limit_deg, positive=True)
        if tl >= 90:
            raise SimulationError(f"tilt limit must be below 90 deg, got {self.tilt_limit_deg!r}")
        set_("tilt_limit_deg", tl)
        set_("xi0", self._pair("initial position xi0", self.xi0))
        set_("zc0", self._pair("initial controller state zc0", self.zc0))
        set_("wind_N", self._pair("wind force", self.wind_N))
        set_("noise_sigma_m", _finite("noise sigma", self.noise_sigma_m, nonneg=True))
        rate = _finite("noise sample rate", self.noise_rate_hz, positive=True)
        if rate * self.dt_s > 1 + 1e-9:
            raise SimulationError(
                f"noise sample rate {rate:g} Hz exceeds the integration rate 1/dt = {1 / self.dt_s:g} Hz"
            )
        set_("noise_rate_hz", rate)
        cs = self.controller_sampling
        if cs is not None:
            if not isinstance(cs, str) or cs not in CONTROLLER_SAMPLING:
                raise SimulationError(f"unknown controller sampling {cs!r} (choose one of "
                                      f"{', '.join(CONTROLLER_SAMPLING)})")
            if self.sample_hold is not None and bool(self.sample_hold) != (cs != "continuous"):
                raise SimulationError(f"sample_hold={self.sample_hold!r} contradicts controller_sampling={cs!r}")
            if cs == "discrete":
                check_rate_hz(rate, self.dt_s, option="noise_rate_hz")
        set_("gust_N", _finite("gust", self.gust_N, nonneg=True))
        set_("gust_tau_s", _finite("gust correlation time", self.gust_tau_s, positive=True))
        if not isinstance(self.seed, (int, np.integer)) or isinstance(self.seed, bool) or self.seed < 0:
            raise SimulationError(f"seed must be a non-negative integer, got {self.seed!r}")
        if self.tau_motor_s is not None:
            set_("tau_motor_s", _finite("motor time constant", self.tau_motor_s, positive=True))
        if self.true_mass_kg is not None:
            set_("true_mass_kg", _finite("true mass", self.true_mass_kg, positive=True))
        if not isinstance(self.inner, InnerLoopGains):
            raise SimulationError("inner must be an InnerLoopGains")
        if self.reference is not None and not isinstance(self.reference, Reference):
            raise SimulationError(f"reference must be a Reference, got {type(self.reference).__name__}")
        if not isinstance(self.feedforward, (bool, np.bool_)):
            raise SimulationError(f"feedforward must be True or False, got {self.feedforward!r}")
        if self.feedforward and self.reference is None:
            raise SimulationError("feedforward needs a reference (it is the reference's acceleration)")
        set_("feedforward_lead_s", _finite("feedforward lead", self.feedforward_lead_s, nonneg=True))
        if self.feedforward_lead_s > 0 and not self.feedforward:
            raise SimulationError("a feedforward lead needs the feedforward")
        set_("v0", self._pair("initial velocity v0", self.v0))
        set_("delay_samples", check_delay_samples(self.delay_samples, sampled=self.sampled))

    @staticmethod
    def _pair(name: str, value: Any) -> tuple[float, float]:
        try:
            a, b = value
        except (TypeError, ValueError):
            raise SimulationError(f"{name} must be a pair of numbers, got {value!r}") from None
        return (_finite(name, a), _finite(name, b))

    @property
    def steps_per_sample(self) -> int:
        """``K = output_dt / dt``."""
        return int(round(self.output_dt_s / self.dt_s))

    @property
    def n_samples(self) -> int:
        """Number of output intervals (the trajectory has one more sample, at t = 0)."""
        return int(math.ceil(self.horizon_s / self.output_dt_s - 1e-9))

    @property
    def sampled(self) -> bool:
        """Whether the position measurement is sampled and held."""
        if self.controller_sampling is not None:
            return self.controller_sampling != "continuous"
        return (self.noise_sigma_m > 0) if self.sample_hold is None else bool(self.sample_hold)

    @property
    def sampling(self) -> str:
        """The resolved :attr:`controller_sampling`: ``"continuous"``, ``"held"`` or ``"discrete"``."""
        if self.controller_sampling is not None:
            return self.controller_sampling
        return "held" if self.sampled else "continuous"

    @property
    def rate_hz(self) -> float:
        """Sample rate of the position measurement (and, when sampled, of the controller) [Hz]."""
        return self.noise_rate_hz

    def with_(self, **changes: Any) -> "SimOptions":
        """Copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["inner"] = self.inner.as_dict()
        d["xi0"], d["zc0"], d["wind_N"] = list(self.xi0), list(self.zc0), list(self.wind_N)
        if d["controller_sampling"] is None:
            # unset: the record of a run stays what it was before the field existed (stated certificate settings)
            del d["controller_sampling"]
        # likewise a run without a reference or motion at the start records what it did before these fields
        if self.reference is None:
            del d["reference"], d["feedforward"], d["feedforward_lead_s"]
        else:
            d["reference"] = self.reference.to_json()
        if self.v0 == (0.0, 0.0):
            del d["v0"]
        else:
            d["v0"] = list(self.v0)
        if not self.delay_samples:
            del d["delay_samples"]
        return d
