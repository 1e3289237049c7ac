"""What a Monte Carlo study may vary: the perturbation ranges, and the ranges a certificate's own box allows.

See :mod:`nniquad.study` for the default ranges and why they were chosen.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any, Mapping

from nniquad.config import (
    ALTITUDE_LIMIT_M,
    CONTROL_RATE_HZ,
    MC_WITHIN_RIM_FRACTION,
    TAU_MOTOR_FACTOR_RANGE,
    WIND_WEIGHT_FRACTION_RANGE,
)
from nniquad.errors import MonteCarloError
from nniquad.validate import finite_int

__all__ = ["ScenarioRanges", "DEFAULT_RANGES", "BOX_KEYS", "certificate_rate_hz", "within_certificate_ranges",
           "certified_delay_samples", "DelayCoverage"]


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
    """Ranges of the random perturbations; every one is drawn uniformly (see :mod:`nniquad.study`).

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
        0-10 %), direction uniform; used unless ``wind_N`` is given.
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
    delay_samples
        Measurement delay of every scenario [samples at ``noise_rate_hz``] (default 0;
        :attr:`nniquad.sim.SimOptions.delay_samples`; ``--within-certificate``: the certified delay).
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
    delay_samples: int = 0

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
        set_("delay_samples", finite_int("delay_samples", self.delay_samples, error=MonteCarloError, minimum=0))

    def with_(self, **changes: Any) -> "ScenarioRanges":
        """Copy with some ranges changed (validated again)."""
        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        # without a delay the record stays what it was before the field existed
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()
                if k != "delay_samples" or v}


DEFAULT_RANGES = ScenarioRanges()


def positive_number_or_none(value: Any) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) and v > 0 else None


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
            v = positive_number_or_none(sec.get("rate_hz"))
            if v is not None:
                return v
    return float(CONTROL_RATE_HZ)


def certified_delay_samples(cert: Mapping[str, Any]) -> int:
    """The measurement delay a certificate certifies [samples]: its ``delay_samples``, 0 when it states none.

    Parameters
    ----------
    cert
        A loaded certificate (a mapping).
    """
    d = cert.get("delay_samples") if isinstance(cert, Mapping) else None
    return d if isinstance(d, int) and not isinstance(d, bool) and d >= 0 else 0


@dataclass(frozen=True)
class DelayCoverage:
    """Whether a certificate covers the measurement delay of a run or study.

    The cascade section proves its loop with exactly :attr:`certified` samples of delay: a longer delay is flagged,
    and a shorter one is a different loop that this proof does not cover either (said, not flagged).

    Attributes
    ----------
    run, certified
        The delay flown and the certificate's [samples].
    """

    run: int
    certified: int

    @property
    def covered(self) -> bool:
        """Whether the run's delay is the certified one."""
        return self.run == self.certified

    @property
    def beyond(self) -> bool:
        """Whether the run's delay exceeds the certified one (flagged)."""
        return self.run > self.certified

    def note(self, what: str = "run") -> str | None:
        """Why the certificate does not cover the delay, or ``None`` when it does.

        Parameters
        ----------
        what
            ``"run"`` or ``"study"`` (the wording).
        """
        if self.covered:
            return None
        if self.beyond:
            return (f"FLAGGED: a measurement delay of {self.run} samples is beyond the certified delay "
                    f"({self.certified} samples): not the certificate's {what}, and nothing certifies it")
        return (f"not covered: a measurement delay of {self.run} samples is shorter than the certified "
                f"{self.certified}; the cascade section proves its loop with exactly {self.certified}, so it does "
                f"not cover this {what}")


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

    The scenarios read the position with the certified measurement delay (the certificate's
    ``delay_samples``, 0 when it states none).

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
    region = positive_number_or_none(roa.get("max_displacement_m")) if isinstance(roa, Mapping) else None
    if region is None:
        raise MonteCarloError("the certificate's cascade section states no region_of_attraction.max_displacement_m")
    rate = positive_number_or_none(cas.get("rate_hz"))
    if rate is None:
        raise MonteCarloError("the certificate's cascade section states no rate_hz")
    ranges = ScenarioRanges(**factors, tau_motor_s=None, noise_sigma_m=(0.0, 0.0), noise_rate_hz=rate,
                            wind_weight_fraction=(0.0, 0.0), wind_N=None, max_displacement_m=region,
                            rim_fraction=MC_WITHIN_RIM_FRACTION, delay_samples=certified_delay_samples(cert))
    return ranges, region, rate
