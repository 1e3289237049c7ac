"""Vehicle parameter sets, with units and sources.

The paper's simulation table (Ghallab & Petersen, Table "Simulation Parameters")
gives m, g, Jx = Jy, Jz, the rotor thrust coefficient b and the rotor drag
coefficient d.  It does not give the arm length l, the rotor inertia Jr, the
rotor-speed limit or a motor time constant.  Its inertias (4.85e-3, 8.81e-3
kg m^2) match, to the third digit, the quadcopter of

    T. Luukkonen, "Modelling and control of quadcopter", Independent research
    project in applied mathematics, Aalto University, Espoo, 2011, Table 1
    (m = 0.468 kg, l = 0.225 m, k = 2.980e-6, b = 1.140e-7,
    Ixx = Iyy = 4.856e-3, Izz = 8.801e-3, rotor inertia I_M = 3.357e-5 kg m^2),

so l and Jr are taken from that table.  No public source states a rotor-speed
limit for that vehicle; we choose ``omega_max`` = 920 rad/s, which gives the
thrust-to-weight ratio of about 2 that small multirotors are usually designed
for (computed by :meth:`Vehicle.thrust_to_weight`: 2.02 for the paper's
vehicle).  The motor time constant (20 ms) is an assumption typical of small
brushless motors with light propellers; the simulations use it only when motor
lag is switched on.

Every field has a unit in :data:`UNITS`.  Vehicles can be loaded from TOML or
JSON files with exactly the field names below.

The rotor layout ``frame`` is ``"+"`` (rotors on the body axes) or ``"x"`` (rotors
between them, 45° off); ``"X"`` is read as ``"x"``.  A vehicle that states no frame
is a '+' vehicle, as every vehicle was before frames existed; for the same reason
:meth:`Vehicle.as_dict` leaves ``frame`` out for a '+' vehicle, so every record
written before (a certificate's vehicle section and its digest) reads the same.
:func:`nniquad.model.symbolic.rotor_geometry` states both layouts.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, Mapping

from nniquad.errors import VehicleError
from nniquad.io import load_data_file
from nniquad.model.layout import DEFAULT_FRAME, FRAMES

__all__ = ["Vehicle", "UNITS", "DESCRIPTIONS", "PAPER_VEHICLE", "load_vehicle", "vehicle_from_mapping"]

UNITS: dict[str, str] = {
    "name": "",
    "m": "kg",
    "g": "m/s^2",
    "Jx": "kg m^2",
    "Jy": "kg m^2",
    "Jz": "kg m^2",
    "b": "N s^2",
    "d": "N m s^2",
    "l": "m",
    "Jr": "kg m^2",
    "omega_max": "rad/s",
    "tau_motor": "s",
    "frame": "",
}

DESCRIPTIONS: dict[str, str] = {
    "name": "label of the parameter set",
    "m": "total mass",
    "g": "gravitational acceleration",
    "Jx": "roll moment of inertia (body x)",
    "Jy": "pitch moment of inertia (body y)",
    "Jz": "yaw moment of inertia (body z)",
    "b": "rotor thrust coefficient, thrust = b * omega^2",
    "d": "rotor drag-torque coefficient, torque = d * omega^2",
    "l": "arm length, centre of mass to rotor axis",
    "Jr": "rotor (propeller + motor bell) inertia about its spin axis",
    "omega_max": "rotor-speed limit",
    "tau_motor": "first-order motor time constant (used only when motor lag is on)",
    "frame": f"rotor layout, one of {', '.join(repr(f) for f in FRAMES)} (default {DEFAULT_FRAME!r})",
}


@dataclass(frozen=True)
class Vehicle:
    """A quadrotor parameter set in SI units (see :data:`UNITS`).

    Instances are validated on construction: every numeric field must be finite
    and positive, the inertias must satisfy the triangle inequality of a rigid
    body, and the rotors must be able to lift the vehicle.
    """

    name: str
    m: float
    g: float
    Jx: float
    Jy: float
    Jz: float
    b: float
    d: float
    l: float
    Jr: float
    omega_max: float
    tau_motor: float
    frame: str = DEFAULT_FRAME

    def __post_init__(self) -> None:
        frame = self.frame.lower() if isinstance(self.frame, str) else self.frame
        if frame not in FRAMES:
            raise VehicleError(f"vehicle field 'frame' must be one of {', '.join(repr(f) for f in FRAMES)} "
                               f"(rotor layout), got {_short(self.frame)}")
        object.__setattr__(self, "frame", frame)
        for f in fields(self):
            if f.name in ("name", "frame"):
                if not isinstance(getattr(self, f.name), str):
                    raise VehicleError(f"vehicle field '{f.name}' must be a string")
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise VehicleError(f"vehicle field '{f.name}' must be a number, got {_short(value)}")
            try:
                v = float(value)  # an int beyond the float range (a 401-digit mass) overflows here
            except OverflowError:
                raise VehicleError(f"vehicle field '{f.name}' must be finite, got an integer beyond the float range "
                                   f"({len(str(value)) if value.bit_length() < 14000 else 'thousands of'} digits)") from None
            if not math.isfinite(v):
                raise VehicleError(f"vehicle field '{f.name}' must be finite, got {_short(value)}")
            if v <= 0.0:
                raise VehicleError(
                    f"vehicle field '{f.name}' ({DESCRIPTIONS[f.name]}) must be positive, got {_short(value)} {UNITS[f.name]}"
                )
            object.__setattr__(self, f.name, v)
        a, b_, c = sorted((self.Jx, self.Jy, self.Jz))
        if c > a + b_ * (1 + 1e-12):
            raise VehicleError(
                f"vehicle inertias Jx={self.Jx}, Jy={self.Jy}, Jz={self.Jz} violate the rigid-body triangle inequality"
            )
        # every derived quantity the model uses must be a finite positive float (omega_max = 1e300
        # overflows the thrust, b = 1e-300 with m = 1e300 the hover speed)
        derived = {
            "weight m g": lambda: self.m * self.g,
            "maximum thrust 4 b omega_max^2": self.max_thrust,
            "thrust-to-weight ratio": self.thrust_to_weight,
            "hover rotor speed sqrt(m g / 4 b)": self.hover_rotor_speed,
            "maximum drag torque d omega_max^2": lambda: self.d * self.omega_max**2,
        }
        for label, compute in derived.items():
            try:
                q = compute()
            except (OverflowError, ZeroDivisionError):
                q = math.inf
            if not (math.isfinite(q) and q > 0.0):
                raise VehicleError(f"vehicle {label} is {'not finite' if not math.isfinite(q) else 'zero'} "
                                   f"with these values (m={self.m:g}, g={self.g:g}, b={self.b:g}, d={self.d:g}, "
                                   f"omega_max={self.omega_max:g})")
        if self.thrust_to_weight() <= 1.0:
            raise VehicleError(
                f"vehicle field 'omega_max' too low: thrust-to-weight {self.thrust_to_weight():.3f} <= 1, it cannot hover"
            )

    def max_thrust(self) -> float:
        """Total thrust with all four rotors at ``omega_max``, in N."""
        return 4.0 * self.b * self.omega_max**2

    def thrust_to_weight(self) -> float:
        """Ratio of the maximum total thrust to the weight m g (dimensionless)."""
        return self.max_thrust() / (self.m * self.g)

    def hover_rotor_speed(self) -> float:
        """Rotor speed at which four rotors carry the weight, in rad/s."""
        return math.sqrt(self.m * self.g / (4.0 * self.b))

    @property
    def frame_index(self) -> int:
        """Position of :attr:`frame` in :data:`nniquad.model.layout.FRAMES` (the generated code's frame entry)."""
        return FRAMES.index(self.frame)

    def as_dict(self) -> dict[str, Any]:
        """Plain dictionary of the fields (JSON/TOML ready); ``frame`` only when it is not '+'.

        A '+' vehicle's dictionary is the one written before frames existed, so a
        certificate's vehicle section and digest read the same (module docstring).
        """
        data = asdict(self)
        if self.frame == DEFAULT_FRAME:
            del data["frame"]
        return data

    def with_(self, **changes: Any) -> "Vehicle":
        """Copy with some fields changed (validated again)."""
        data = self.as_dict()
        data.update(changes)
        return vehicle_from_mapping(data)

    def describe(self) -> str:
        """Multi-line table of the parameters with units and the derived ratios."""
        rows = [f"{'field':<10} {'value':>12}  unit      meaning"]
        for key, value in self.as_dict().items():
            if key in ("name", "frame"):
                continue
            rows.append(f"{key:<10} {value:>12.6g}  {UNITS[key]:<9} {DESCRIPTIONS[key]}")
        rows.append(f"{'frame':<10} {self.frame:>12}  {'-':<9} {DESCRIPTIONS['frame']}")
        rows.append(f"{'T/W':<10} {self.thrust_to_weight():>12.4g}  {'-':<9} thrust-to-weight ratio at omega_max")
        rows.append(f"{'omega_hov':<10} {self.hover_rotor_speed():>12.6g}  {'rad/s':<9} hover rotor speed")
        return "\n".join(rows)


Vehicle.__doc__ = (Vehicle.__doc__ or "").rstrip() + "\n\n    Attributes\n    ----------\n" + "".join(
    f"    {name}\n        {DESCRIPTIONS[name]}" + (f" [{UNITS[name]}]" if UNITS[name] else "") + ".\n"
    for name in UNITS)

PAPER_VEHICLE = Vehicle(
    name="Ghallab & Petersen simulation vehicle (l, Jr from Luukkonen 2011)",
    m=0.5,
    g=9.81,
    Jx=4.85e-3,
    Jy=4.85e-3,
    Jz=8.81e-3,
    b=2.92e-6,
    d=1.12e-7,
    l=0.225,
    Jr=3.357e-5,
    omega_max=920.0,
    tau_motor=0.02,
)


def vehicle_from_mapping(data: Mapping[str, Any], *, source: str = "vehicle") -> Vehicle:
    """Build a validated :class:`Vehicle` from a mapping of field names to values.

    Raises
    ------
    VehicleError
        On a missing or unknown field, a non-numeric, non-finite or non-positive
        value, or a physically impossible combination.
    """
    if not isinstance(data, Mapping):
        raise VehicleError(f"{source}: expected a table of fields, got {type(data).__name__}")
    known = [f.name for f in fields(Vehicle)]
    unknown = sorted(set(data) - set(known), key=str)
    if unknown:
        raise VehicleError(f"{source}: unknown field {_short(str(unknown[0]), 40)} (known fields: {', '.join(known)})")
    values = dict(data)
    values.setdefault("name", source)
    missing = [k for k in known if k not in values and k != "frame"]
    if missing:
        raise VehicleError(f"{source}: missing field '{missing[0]}' ({DESCRIPTIONS[missing[0]]}, {UNITS[missing[0]]})")
    try:
        return Vehicle(**values)
    except VehicleError as exc:
        raise VehicleError(f"{source}: {exc}") from None


def load_vehicle(path: str | Path | None) -> Vehicle:
    """Load a vehicle from a ``.toml`` or ``.json`` file; ``None`` gives the paper's vehicle.

    The file is read by :func:`nniquad.io.load_data_file` (regular file, bounded
    size, UTF-8, no duplicate keys, bounded nesting and integers).

    Parameters
    ----------
    path
        A ``.toml`` or ``.json`` file with the fields of :class:`Vehicle`, or ``None``.

    Raises
    ------
    VehicleError
        If the file cannot be read or parsed, or its content is invalid.
    """
    if path is None:
        return PAPER_VEHICLE

    data = load_data_file(path, what="vehicle file", error=VehicleError, formats=("toml", "json"))
    return vehicle_from_mapping(data, source=str(Path(path)))


def _short(value: Any, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters (a message stays one readable line)."""
    try:
        text = repr(value)
    except ValueError:  # an int beyond Python's int-to-str limit
        return f"a {type(value).__name__} too long to print"
    text = text.replace("\n", " ")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def vehicle_to_toml(vehicle: Vehicle) -> str:
    """TOML text of a vehicle with units as comments (a template users can edit)."""
    lines = [f'name = "{vehicle.name}"']
    for key, value in vehicle.as_dict().items():
        if key not in ("name", "frame"):
            lines.append(f"{key} = {value!r}  # {UNITS[key]}: {DESCRIPTIONS[key]}")
    lines.append(f'frame = "{vehicle.frame}"  # {DESCRIPTIONS["frame"]}')
    return "\n".join(lines) + "\n"
