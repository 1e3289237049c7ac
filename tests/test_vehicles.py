"""Any user's vehicle: the committed vehicle files, and the refusal of what no design can fly.

Fast tests: the feasibility limits worked out by hand, and ``certify`` refusing an infeasible vehicle file at
once, with one line naming the limit and no file written.  Slow tests: ``certify --model full --budget quick`` on
each committed vehicle file either writes a certificate whose reference runs settle (and verify) or refuses with
one line.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import pytest

from nniquad.config import WIND_WEIGHT_FRACTION_RANGE
from nniquad.model.vehicle import PAPER_VEHICLE, load_vehicle
from nniquad.tuning.vehicle_limits import check_feasible, feasibility_problems
from nniquad.errors import VehicleError

VEHICLES = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "vehicles"
FILES = sorted(p.stem for p in VEHICLES.glob("*.toml"))


def _write_vehicle(path: Path, vehicle) -> Path:
    lines = []
    for key, value in vehicle.as_dict().items():
        lines.append(f"{key} = {json.dumps(value) if isinstance(value, str) else repr(float(value))}")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_committed_vehicle_files_state_their_sources():
    assert FILES == ["crazyflie2", "iris", "iris_x"]
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    for name, sources in (("crazyflie2", ("Foerster", "cf2x.urdf", "crazyflie2.xacro")),
                          ("iris", ("iris.sdf", "iris.xacro")), ("iris_x", ("iris.sdf", "iris.xacro", "Crazyflie"))):
        text = (VEHICLES / f"{name}.toml").read_text()
        for s in sources:
            assert s in text, (name, s)
        assert f"notebooks/data/vehicles/{name}.toml" in readme


@pytest.mark.parametrize("name", ["paper", *FILES])
def test_committed_vehicles_pass_the_feasibility_limits(name):
    vehicle = PAPER_VEHICLE if name == "paper" else load_vehicle(VEHICLES / f"{name}.toml")
    assert feasibility_problems(vehicle) == []
    check_feasible(vehicle)


def test_feasibility_limits_by_hand():
    v = PAPER_VEHICLE
    # thrust: 4 b w^2 cos 30 must exceed m g.  At thrust-to-weight 1.15 < 1/cos 30 = 1.1547 it does not;
    # at 1.16 it does.
    for tw, refused in ((1.15, True), (1.16, False)):
        w = math.sqrt(tw * v.m * v.g / (4 * v.b))
        problems = feasibility_problems(replace(v, omega_max=w))
        assert any(p.startswith("thrust: thrust-to-weight 1.15") for p in problems) == refused, problems
    # motor lag: wn_a <= 0.75/tau (zeta 1.5, factor 2, margin 2); kp_max = (wn_a/3)^2 <= 0.5 iff tau >= 0.75/(3 sqrt .5)
    tau_edge = 0.75 / (3 * math.sqrt(0.5))
    assert any(p.startswith("motor lag") for p in feasibility_problems(replace(v, tau_motor=1.01 * tau_edge)))
    assert not any(p.startswith("motor lag") for p in feasibility_problems(replace(v, tau_motor=0.99 * tau_edge)))
    # wind: 10 % of the weight against tan(tilt): tan 5.7 deg = 9.98 % is refused, tan 5.8 deg = 10.16 % is not
    assert any(p.startswith("wind") for p in feasibility_problems(v, tilt_limit_deg=5.7, wind_fraction_max=0.10))
    assert not any(p.startswith("wind") for p in feasibility_problems(v, tilt_limit_deg=5.8, wind_fraction_max=0.10))
    # the default wind is the Monte Carlo range's upper end
    edge = math.degrees(math.atan(WIND_WEIGHT_FRACTION_RANGE[1]))
    assert any(p.startswith("wind") for p in feasibility_problems(v, tilt_limit_deg=0.99 * edge))
    assert not any(p.startswith("wind") for p in feasibility_problems(v, tilt_limit_deg=1.01 * edge))
    weak_slow = replace(v, omega_max=math.sqrt(1.1 * v.m * v.g / (4 * v.b)), tau_motor=1.0)
    with pytest.raises(VehicleError, match=r"cannot fly a design: thrust: .*\(and 1 more limit"):
        check_feasible(weak_slow)


@pytest.mark.parametrize("change, limit", [({"omega_max": 680.0}, "thrust-to-weight 1.1 is below 1/cos(tilt limit)"),
                                           ({"tau_motor": 0.5}, "motor lag: tau_motor = 0.5 s")],
                         ids=["weak-rotors", "slow-motors"])
def test_certify_refuses_an_infeasible_vehicle_at_once_naming_the_limit(run_cli, tmp_path, change, limit):
    import time

    path = _write_vehicle(tmp_path / "v.toml", replace(PAPER_VEHICLE, name="weak", **change))
    out = tmp_path / "cert.json"
    t0 = time.perf_counter()
    code, _, err = run_cli("certify", "--model", "full", "--vehicle", str(path), "--out", str(out))
    assert code == 2, err
    lines = [line for line in err.strip().splitlines() if "error" in line]
    assert len(lines) == 1 and limit in lines[0] and "Traceback" not in err, err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["v.toml"]
    assert time.perf_counter() - t0 < 30  # refused before any tuning (a normal tune takes minutes)


@pytest.mark.slow
# iris_x is the Iris as an X frame: its quick certify takes the Iris's path (a minute); test_frames certifies an
# X frame in seconds, and benchmarks/bench_vehicles.py certifies every file
@pytest.mark.parametrize("name", [name for name in FILES if name != "iris_x"])
def test_certify_full_on_each_vehicle_file_settles_or_refuses_with_one_line(run_cli, tmp_path, name):
    from nniquad.certificates import load_certificate, verify_certificate

    out = tmp_path / "cert.json"
    code, _, err = run_cli("certify", "--model", "full", "--budget", "quick", "--vehicle",
                           str(VEHICLES / f"{name}.toml"), "--out", str(out))
    if code != 0:  # a refusal: one line, nothing written
        lines = [line for line in err.strip().splitlines() if "error" in line]
        assert len(lines) == 1 and "Traceback" not in err and not out.exists(), err
        return
    cert = load_certificate(out)
    for model in ("reduced", "full"):  # the certificate's own reference runs settle
        assert cert["performance"][model]["settling_s"] is not None, model
    assert verify_certificate(cert).ok
