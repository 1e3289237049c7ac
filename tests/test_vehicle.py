"""Vehicle parameter sets: validation, files, derived ratios."""

from __future__ import annotations

import json
import math

import pytest

from nniquad.errors import VehicleError
from nniquad.model.vehicle import PAPER_VEHICLE, UNITS, load_vehicle, vehicle_to_toml


def test_paper_vehicle_matches_paper_table():
    # values of the paper's simulation-parameter table
    v = PAPER_VEHICLE
    assert (v.m, v.g, v.Jx, v.Jy, v.Jz, v.b, v.d) == (0.5, 9.81, 4.85e-3, 4.85e-3, 8.81e-3, 2.92e-6, 1.12e-7)


def test_every_field_has_a_unit():
    from dataclasses import fields

    from nniquad.model.vehicle import Vehicle

    assert set(UNITS) == {f.name for f in fields(Vehicle)}


def test_thrust_to_weight_by_hand():
    v = PAPER_VEHICLE
    # 4 rotors, thrust b w^2 each, against m g
    assert v.thrust_to_weight() == pytest.approx(4 * 2.92e-6 * 920.0**2 / (0.5 * 9.81), rel=1e-12)
    # hover speed squares back to the weight
    assert 4 * v.b * v.hover_rotor_speed() ** 2 == pytest.approx(v.m * v.g, rel=1e-12)


def _write(tmp_path, name, data):
    p = tmp_path / name
    if name.endswith(".json"):
        p.write_text(json.dumps(data))
    else:
        p.write_text(data)
    return p


def test_toml_round_trip(tmp_path):
    p = tmp_path / "v.toml"
    p.write_text(vehicle_to_toml(PAPER_VEHICLE))
    assert load_vehicle(p) == PAPER_VEHICLE


def test_json_file(tmp_path):
    p = _write(tmp_path, "v.json", PAPER_VEHICLE.as_dict() | {"m": 0.7})
    assert load_vehicle(p).m == 0.7


@pytest.mark.parametrize(
    "change, message",
    [
        ({"m": -0.5}, "'m'"),
        ({"m": 0.0}, "'m'"),
        ({"Jx": -1e-3}, "'Jx'"),
        ({"Jz": 0}, "'Jz'"),
        ({"b": float("nan")}, "'b'"),
        ({"l": "long"}, "'l'"),
        ({"colour": "red"}, "unknown field 'colour'"),
        ({"omega_max": 100.0}, "'omega_max'"),
        ({"Jz": 1.0}, "triangle inequality"),
    ],
)
def test_bad_vehicle_rejected(tmp_path, change, message):
    data = PAPER_VEHICLE.as_dict() | change
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(data, allow_nan=True))
    with pytest.raises(VehicleError, match=message.replace("(", r"\(")):
        load_vehicle(p)


def test_missing_field(tmp_path):
    data = PAPER_VEHICLE.as_dict()
    del data["Jr"]
    p = _write(tmp_path, "v.json", data)
    with pytest.raises(VehicleError, match="missing field 'Jr'"):
        load_vehicle(p)


def test_infinite_value_in_toml(tmp_path):
    text = vehicle_to_toml(PAPER_VEHICLE).replace("g = 9.81", "g = inf")
    p = tmp_path / "v.toml"
    p.write_text(text)
    with pytest.raises(VehicleError, match="'g' must be finite"):
        load_vehicle(p)


def test_malformed_files(tmp_path):
    p = tmp_path / "v.json"
    p.write_text("{not json")
    with pytest.raises(VehicleError, match="not valid JSON"):
        load_vehicle(p)
    q = tmp_path / "v.yaml"
    q.write_text("m: 1")
    with pytest.raises(VehicleError, match="unsupported extension"):
        load_vehicle(q)
    with pytest.raises(VehicleError, match="cannot read"):
        load_vehicle(tmp_path / "absent.toml")


def test_cli_bad_vehicle_one_line_no_traceback(tmp_path, run_cli):
    p = tmp_path / "v.json"
    p.write_text(json.dumps(PAPER_VEHICLE.as_dict() | {"m": -1}))
    code, out, err = run_cli("vehicle", "--vehicle", str(p))
    assert code == 2
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and "'m'" in err


def test_cli_vehicle_write(tmp_path, run_cli):
    target = tmp_path / "mine.toml"
    code, out, err = run_cli("vehicle", "--write", str(target))
    assert code == 0 and "kg" in out
    assert load_vehicle(target) == PAPER_VEHICLE
    assert math.isclose(load_vehicle(target).thrust_to_weight(), PAPER_VEHICLE.thrust_to_weight())
