"""The parameter vector of the compiled simulation functions, generated from the typed blocks.

Gains, vehicle and run settings are *inputs* of the compiled functions (the
vector ``p``), so one compiled function serves many gain sets, perturbed
vehicles and scenarios.  Its layout is not kept by hand: :func:`param_layout`
reads it from the fields of five typed blocks, in this order,

============  ====================================================  ===============================
group         block                                                 what it is
============  ====================================================  ===============================
``gains``     the law's gain block (:attr:`ControlLaw.gains_type`)  horizontal controller
``nominal``   :class:`VehicleParams` (the :class:`Vehicle` fields)  what the controller assumes
``inner``     :class:`nniquad.control.inner_gains.InnerLoopGains`   inner loops (``full``)
``plant``     :class:`VehicleParams`                                the true vehicle
``run``       :class:`RunSettings`                                  tilt limit, motor lag, wind, ...
============  ====================================================  ===============================

and the entries are named ``group.field`` (``"gains.kp"``, ``"plant.m"``,
``"inner.attitude_wn_rad_s"``, ``"run.dt"``), each with its unit.  The gain
part differs per law (NNI: ``kp, Gamma, delta, kpy``; PD with true
velocity: ``kp, kd``; PD with filtered derivative: ``kp, kd, tau_f``; every
registered law of :mod:`nniquad.laws` its own fields), so each law has its own
layout and its own compiled function.

:class:`SimParams` holds one such parameter set as typed blocks.
:class:`VehicleParams` is not validated beyond finiteness: a Monte Carlo plant
may be one that cannot hover (it then falls, and the study counts it).
"""

from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, field, fields, make_dataclass, replace
from functools import lru_cache
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np

from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import SimulationError
from nniquad.laws.base import GainBlock, field_unit
from nniquad.laws.registry import law_named, law_names, to_gains as _registry_gains
from nniquad.model.layout import DEFAULT_FRAME, FRAMES, STATE_ORDER
from nniquad.model.vehicle import DESCRIPTIONS, UNITS, Vehicle

__all__ = [
    "EXO_FIELDS",
    "STATE_NAMES",
    "state_names",
    "delay_state_names",
    "OUTPUT_NAMES",
    "ParamField",
    "VehicleParams",
    "RunSettings",
    "SimParams",
    "param_layout",
    "n_params",
    "to_gains",
    "check_controller",
]

#: Per-step exogenous input ``e``: position noise [m], sample flag, gust force [N], and the reference the
#: controller reads: position ``ξ_d`` [m], velocity ``ξ̇_d`` [m/s] (read only by a law that measures the
#: velocity) and the acceleration feedforward ``a_ff`` [m/s²] (zero without feedforward).  The sample flag is
#: 0 between samples, 1 at the first sample of a run (the measurement is latched) and 2 at every later
#: sample (the discrete controller first advances one period on the previous held value, then the
#: measurement is latched); the continuous and held variants treat 1 and 2 alike.  The reference is
#: an input, not a parameter, so one compiled function serves every reference (and none: zeros).
EXO_FIELDS: tuple[str, ...] = ("noise_x", "noise_y", "sample_flag", "gust_x", "gust_y",
                               "ref_x", "ref_y", "ref_vx", "ref_vy", "ff_x", "ff_y")


def state_names(model: str, controller: str = "nni", delay_samples: int = 0) -> tuple[str, ...]:
    """State of a model with a controller law: the plant, the law's controller states
    (:attr:`nniquad.laws.base.ControlLaw.sim_state_names`: ``zc_x, zc_y`` for a one-state law, ``sni2`` adds
    ``zcd_x, zcd_y``), the sampled-and-held measurement ``held_*``, on ``full`` the altitude integrator and
    the rotor speeds, and last the measurement delay line (:func:`delay_state_names`).

    Parameters
    ----------
    model
        ``"linear"``, ``"reduced"`` or ``"full"``.
    controller
        A registered law's name.
    delay_samples
        Length of the measurement delay line [samples] (:attr:`nniquad.sim.options.SimOptions.delay_samples`).
    """
    ctrl = law_named(check_controller(controller)).sim_state_names
    if model in ("linear", "reduced"):
        return ("x", "x_dot", "y", "y_dot") + ctrl + ("held_x", "held_y") + delay_state_names(delay_samples)
    if model == "full":
        return (STATE_ORDER + ctrl + ("held_x", "held_y", "z_int", "w1", "w2", "w3", "w4")
                + delay_state_names(delay_samples))
    raise SimulationError(f"unknown model {model!r} (choose one of linear, reduced, full)")


def delay_state_names(delay_samples: int) -> tuple[str, ...]:
    """The measurement delay line: ``zcd1_x, zcd1_y, ..., zcdN_x, zcdN_y``, ``zcdj`` the measurement ``j``
    samples old (before the latch of a sample).  The names start with ``zc`` and end with the axis, so the
    cascade certificate's subsystems (:func:`nniquad.analysis.cascade.family.subsystems`) count them as the
    axis's controller states.

    Parameters
    ----------
    delay_samples
        Number of samples ``N``.
    """
    return tuple(f"zcd{j}_{axis}" for j in range(1, int(delay_samples) + 1) for axis in ("x", "y"))


#: State of each model with a one-state controller law (:func:`state_names` of the NNI law).
STATE_NAMES: dict[str, tuple[str, ...]] = {
    "linear": ("x", "x_dot", "y", "y_dot", "zc_x", "zc_y", "held_x", "held_y"),
    "full": STATE_ORDER + ("zc_x", "zc_y", "held_x", "held_y", "z_int", "w1", "w2", "w3", "w4"),
}
STATE_NAMES["reduced"] = STATE_NAMES["linear"]

#: Outputs of each model: commanded acceleration after the tilt limit, commanded tilt, ...
OUTPUT_NAMES: dict[str, tuple[str, ...]] = {
    "linear": ("a_x", "a_y", "tilt_cmd", "phi", "theta"),
    "full": ("a_x", "a_y", "tilt_cmd", "w1", "w2", "w3", "w4", "u1", "wc1", "wc2", "wc3", "wc4"),
}
OUTPUT_NAMES["reduced"] = OUTPUT_NAMES["linear"]


def check_controller(controller: str) -> str:
    """``controller`` if it names a registered law (:mod:`nniquad.laws`), else :class:`SimulationError`.

    Parameters
    ----------
    controller
        The law's name.
    """
    if not isinstance(controller, str) or controller not in law_names():
        raise SimulationError(f"unknown controller {controller!r} (choose one of {', '.join(law_names())})")
    return controller


# =============================================================================== typed blocks

#: Vehicle parameters that are numbers: the numeric fields and the frame as its index in
#: :data:`nniquad.model.layout.FRAMES` (the vehicle's name is not a parameter).
_VEHICLE_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(Vehicle) if f.name not in ("name", "frame")) + (
    "frame_index",)
_VEHICLE_META: dict[str, tuple[str, str]] = {
    **{n: (UNITS[n], DESCRIPTIONS[n]) for n in _VEHICLE_FIELDS if n in UNITS},
    "frame_index": ("-", f"rotor layout, index in {FRAMES} ({DESCRIPTIONS['frame']})"),
}

VehicleParams = make_dataclass(
    "VehicleParams",
    [(n, float, field(metadata={"unit": _VEHICLE_META[n][0], "meaning": _VEHICLE_META[n][1]}))
     for n in _VEHICLE_FIELDS],
    frozen=True,
    namespace={
        "__doc__": "The numeric fields of a :class:`nniquad.model.vehicle.Vehicle` and its frame's index, "
                   "unvalidated (a perturbed plant may be one that cannot hover).",
        "from_vehicle": classmethod(lambda cls, v: cls(**{n: float(getattr(v, n)) for n in _VEHICLE_FIELDS})),
        "values": lambda self: {n: getattr(self, n) for n in _VEHICLE_FIELDS},
        # a table written before frames existed has no frame_index: a '+' vehicle
        "from_values": classmethod(lambda cls, d: cls(**{n: d.get(n, float(FRAMES.index(DEFAULT_FRAME))) if n == "frame_index" else d[n]
                                                          for n in _VEHICLE_FIELDS})),
    },
)
VehicleParams.__module__ = __name__


def _u(unit: str, meaning: str) -> Any:
    return field(metadata={"unit": unit, "meaning": meaning})


@dataclass(frozen=True)
class RunSettings:
    """Settings of a run that enter the compiled functions (the rest stays in :class:`SimOptions`).

    Attributes
    ----------
    tilt_limit
        Tilt limit [rad] (``reduced``, ``full``).
    motor_lag
        1 with the first-order rotor-speed lag, else 0.
    wind_x, wind_y
        Constant wind force, north / east [N].
    sample_hold
        1 when the position measurement is sampled and held, else 0 (continuous).
    dt
        Integration step [s].
    discrete
        1 when the horizontal law runs in discrete time (exact ZOH of its state
        equation, period ``sample_period``; needs ``sample_hold``), else 0.
    sample_period
        Sample period ``T`` of the measurement and of the discrete controller [s].
    """

    tilt_limit: float = _u("rad", "tilt limit (reduced, full)")
    motor_lag: float = _u("0/1", "motor lag on")
    wind_x: float = _u("N", "constant wind force, north")
    wind_y: float = _u("N", "constant wind force, east")
    sample_hold: float = _u("0/1", "position measurement sampled and held (else continuous)")
    dt: float = _u("s", "integration step")
    discrete: float = field(default=0.0, metadata={"unit": "0/1", "meaning": "horizontal law in discrete time "
                                                                            "(exact ZOH at the sample period)"})
    sample_period: float = field(default=0.01, metadata={"unit": "s", "meaning": "sample period of the "
                                                                                 "measurement and the controller"})

    def values(self) -> dict[str, float]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_values(cls, d: Mapping[str, float]) -> "RunSettings":
        # the two discrete-controller fields may be missing (settings written before they existed)
        return cls(**{f.name: d[f.name] for f in fields(cls) if f.name in d or f.default is MISSING})


# =============================================================================== layout


class ParamField(NamedTuple):
    """One entry of the parameter vector: ``group.field`` name, unit, meaning."""

    name: str
    unit: str
    meaning: str


#: Groups of :class:`SimParams`, in vector order, with the meaning prefix of their entries.
_GROUPS: tuple[tuple[str, str], ...] = (("gains", ""), ("nominal", "assumed by the controller: "), ("inner", ""),
                                        ("plant", "true plant: "), ("run", ""))


def _block_type(group: str, controller: str) -> type:
    if group == "gains":
        return law_named(controller).gains_type
    return {"nominal": VehicleParams, "inner": InnerLoopGains, "plant": VehicleParams, "run": RunSettings}[group]


@lru_cache(maxsize=None)
def param_layout(controller: str = "nni") -> tuple[ParamField, ...]:
    """Layout of the parameter vector of one controller, generated from the blocks' fields.

    Parameters
    ----------
    controller
        A registered law's name.

    Returns
    -------
    tuple of ParamField
        ``(name, unit, meaning)`` in vector order, names ``group.field``.
    """
    out = []
    for group, prefix in _GROUPS:
        for f in fields(_block_type(group, check_controller(controller))):
            unit, meaning = field_unit(f)
            out.append(ParamField(f"{group}.{f.name}", unit, prefix + meaning))
    return tuple(out)


def n_params(controller: str = "nni") -> int:
    """Length of the parameter vector of ``controller``."""
    return len(param_layout(controller))


# =============================================================================== gains


def to_gains(gains: Any, controller: str | None = None) -> GainBlock:
    """A typed gain block from a block, a mapping or a tuple (:func:`nniquad.laws.registry.to_gains`).

    Parameters
    ----------
    gains
        A gain block (returned as it is), or a mapping / tuple of the fields of the ``controller``'s block
        (``(kp, Gamma, delta[, kpy])``, ``(kp, kd)``, ``(kp, kd[, tau_f])``, ...).
    controller
        The law the gains must be for; ``None`` accepts any block and reads a mapping or tuple as NNI gains.

    Raises
    ------
    GainError
        Missing, unknown, non-finite or non-positive gains, or a block of another law.
    SimulationError
        An unknown law.
    """
    if controller is not None:
        check_controller(controller)
    return _registry_gains(gains, controller)


# =============================================================================== parameter set


@dataclass(frozen=True)
class SimParams:
    """One parameter set of the compiled simulation functions, as typed blocks.

    Attributes
    ----------
    gains
        The controller's gain block; its type is the controller law (``gains.controller``).
    nominal
        The vehicle the controller and the inner loops assume.
    inner
        The inner-loop gains.
    plant
        The true vehicle.
    run
        Tilt limit, motor lag, wind, sampling and step (:class:`RunSettings`).

    Notes
    -----
    Build one with :meth:`from_options`; perturb it with :meth:`with_`, e.g.
    ``p.with_(plant={"m": 0.6}, inner={"attitude_gain_scale": 1.2})``; pass it
    (or a list) to :func:`nniquad.sim.simulate` as ``params``.
    """

    gains: GainBlock
    nominal: Any  # VehicleParams
    inner: InnerLoopGains
    plant: Any  # VehicleParams
    run: RunSettings

    def __post_init__(self) -> None:
        g = to_gains(self.gains)
        object.__setattr__(self, "gains", type(g).from_values(g.values()))  # canonical (kpy = kp -> None)

    @property
    def controller(self) -> str:
        """The controller law (from the type of :attr:`gains`)."""
        return self.gains.controller

    @property
    def layout(self) -> tuple[ParamField, ...]:
        """:func:`param_layout` of this controller."""
        return param_layout(self.controller)

    @classmethod
    def from_options(cls, vehicle: Vehicle, gains: Any, options: Any) -> "SimParams":
        """Nominal controller = ``vehicle``; plant = ``vehicle`` with the options' true mass and motor time constant.

        Parameters
        ----------
        vehicle
            The vehicle.
        gains
            A gain block (or a mapping / tuple of NNI gains, :func:`to_gains`).
        options
            A :class:`nniquad.sim.options.SimOptions`.
        """
        nominal = VehicleParams.from_vehicle(vehicle)
        plant = replace(nominal, m=nominal.m if options.true_mass_kg is None else options.true_mass_kg,
                        tau_motor=nominal.tau_motor if options.tau_motor_s is None else options.tau_motor_s)
        run = RunSettings(tilt_limit=math.radians(options.tilt_limit_deg), motor_lag=1.0 if options.motor_lag else 0.0,
                          wind_x=options.wind_N[0], wind_y=options.wind_N[1],
                          sample_hold=1.0 if options.sampled else 0.0, dt=options.dt_s,
                          discrete=1.0 if options.sampling == "discrete" else 0.0,
                          sample_period=1.0 / options.noise_rate_hz)
        return cls(to_gains(gains), nominal, options.inner, plant, run)

    def with_(self, **changes: Any) -> "SimParams":
        """Copy with blocks replaced, or some of their fields changed.

        Each keyword is a group (``gains``, ``nominal``, ``inner``, ``plant``,
        ``run``) and its value a new block or a mapping of field changes.
        """
        new = {}
        for group, value in changes.items():
            if group not in {g for g, _ in _GROUPS}:
                raise SimulationError(f"SimParams has no group '{group}' (groups: {', '.join(g for g, _ in _GROUPS)})")
            if isinstance(value, Mapping):
                block = getattr(self, group)
                value = type(block).from_values({**block.values(), **{k: float(v) for k, v in value.items()}})
            new[group] = value
        return replace(self, **new)

    def values(self) -> dict[str, float]:
        """``{"group.field": value}`` in :attr:`layout` order."""
        out: dict[str, float] = {}
        for group, _ in _GROUPS:
            for k, v in getattr(self, group).values().items():
                out[f"{group}.{k}"] = float(v)
        return out

    def vector(self) -> np.ndarray:
        """The vector ``p`` in :attr:`layout` order."""
        return np.array(list(self.values().values()), dtype=float)

    @classmethod
    def from_vector(cls, p: Sequence[float], controller: str = "nni") -> "SimParams":
        """Inverse of :meth:`vector` for the ``controller``'s layout."""
        layout = param_layout(controller)
        p = np.asarray(p, float).reshape(-1)
        if p.size != len(layout):
            raise SimulationError(f"parameter vector of {controller} must have {len(layout)} entries, got {p.size}")
        by_group: dict[str, dict[str, float]] = {g: {} for g, _ in _GROUPS}
        for f, v in zip(layout, p):
            group, name = f.name.split(".", 1)
            by_group[group][name] = float(v)
        return cls(**{g: _block_type(g, controller).from_values(by_group[g]) for g, _ in _GROUPS})
