"""Property-based tests (hypothesis): any bytes, types or values give a valid object or the project's one-line error.

Three readers are attacked: the vehicle reader (bytes, and JSON of any type in
every field), the certificate reader (bytes, and a signed certificate with any
value at any place, re-signed or not) and the numeric options of the command
line.  For the options the expensive step of each command is replaced by a
stub that stops the run with a sentinel status: reaching it means every
option was accepted before any work, which is the other allowed outcome.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nniquad.certificates.certificate import canonical_digest, load_certificate
from nniquad.certificates.verify import verify_certificate
from nniquad.errors import CertificateError, VehicleError
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle, load_vehicle, vehicle_from_mapping

CERT = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"
FIELDS = list(PAPER_VEHICLE.as_dict())
#: Derandomized (the same examples on every run and machine) and no example database left in the work tree.
SETTINGS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

#: Any JSON value, including the awkward ones (huge ints, non-finite floats, deep nesting).
json_scalars = st.one_of(
    st.none(), st.booleans(), st.text(max_size=30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**450), max_value=10**450),
)
json_values = st.recursive(json_scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)), max_leaves=12)
#: A numeric field: mostly plausible numbers, often extreme ones.
numbers = st.one_of(
    st.floats(min_value=1e-6, max_value=1e3),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**420), max_value=10**420),
    st.sampled_from([0, -0.0, 1e300, 1e-300, 5e-324, 10**401]),
)


def _write(tmp_path: Path, name: str, data: bytes) -> Path:
    p = tmp_path / name
    p.write_bytes(data)
    return p


# ============================================================================ vehicle reader


@SETTINGS
@given(data=st.binary(max_size=2000), suffix=st.sampled_from([".json", ".toml"]))
def test_vehicle_reader_any_bytes(tmp_path, data, suffix):
    p = _write(tmp_path, "v" + suffix, data)
    try:
        v = load_vehicle(p)
    except VehicleError as exc:
        assert "\n" not in str(exc) and str(p) in str(exc)
    else:
        assert isinstance(v, Vehicle)


@SETTINGS
@given(changes=st.dictionaries(st.sampled_from(FIELDS), st.one_of(numbers, json_values), max_size=4),
       fmt=st.sampled_from(["json", "toml"]))
def test_vehicle_reader_any_field_values(tmp_path, changes, fmt):
    data = {**PAPER_VEHICLE.as_dict(), **changes}
    if fmt == "json":
        text = json.dumps(data, allow_nan=True)
    else:
        lines = []
        for k, v in data.items():
            if isinstance(v, float) and not math.isfinite(v):
                lines.append(f"{k} = {'nan' if math.isnan(v) else ('inf' if v > 0 else '-inf')}")
            elif isinstance(v, (dict, list)) or v is None:
                lines.append(f"{k} = {json.dumps(json.dumps(v))}")  # a string: TOML has no null
            else:
                lines.append(f"{k} = {json.dumps(v)}")
        text = "\n".join(lines) + "\n"
    p = _write(tmp_path, f"v.{fmt}", text.encode())
    try:
        v = load_vehicle(p)
    except VehicleError as exc:
        assert "\n" not in str(exc)
    else:
        # a vehicle that loads has finite, positive derived quantities
        assert math.isfinite(v.thrust_to_weight()) and v.thrust_to_weight() > 1
        assert math.isfinite(v.hover_rotor_speed()) and v.hover_rotor_speed() > 0


@SETTINGS
@given(values=st.dictionaries(st.sampled_from(FIELDS), st.one_of(numbers, json_values), max_size=12))
def test_vehicle_from_any_mapping(values):
    try:
        v = vehicle_from_mapping({**PAPER_VEHICLE.as_dict(), **values})
    except VehicleError as exc:
        assert "\n" not in str(exc)
    else:
        assert all(math.isfinite(getattr(v, f)) for f in FIELDS if f != "name")


# ============================================================================ certificate reader

_CERT = json.loads(CERT.read_text())


def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


CERT_PATHS = [p for p in _paths(_CERT) if p and p[0] != "digest"]


@SETTINGS
@given(data=st.binary(max_size=3000))
def test_certificate_reader_any_bytes(tmp_path, data):
    p = _write(tmp_path, "c.json", data)
    with pytest.raises(CertificateError) as info:
        load_certificate(p)
    assert "\n" not in str(info.value)


@SETTINGS
@given(path=st.sampled_from(CERT_PATHS), value=json_values, resign=st.booleans())
def test_certificate_any_value_anywhere(tmp_path, path, value, resign):
    cert = copy.deepcopy(_CERT)
    node = cert
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    if resign:
        try:
            cert["digest"]["value"] = canonical_digest(cert)
        except (TypeError, ValueError):
            pass  # NaN cannot be signed; the unsigned document must still be refused cleanly
    try:
        text = json.dumps(cert, allow_nan=True)
    except ValueError:  # an int beyond Python's int-to-str limit cannot even be written
        return
    p = _write(tmp_path, "c.json", text.encode())
    try:
        loaded = load_certificate(p)
        result = verify_certificate(loaded, simulate=False)
    except CertificateError as exc:
        assert "\n" not in str(exc)
    else:
        assert isinstance(result.ok, bool)


# ============================================================================ numeric options of the CLI


class _Reached(SystemExit):
    """Raised by the stubs: every option was accepted and the work was about to start."""


REACHED = 99


@pytest.fixture
def stubbed(monkeypatch):
    """Replace the first expensive step of each command by a stub that exits with :data:`REACHED`."""
    import importlib

    import nniquad.resources as resources

    def stop(*args, **kwargs):
        raise _Reached(REACHED)

    # the first expensive call of each command (looked up at call time by the command modules)
    for module, name in (("nniquad.sim", "simulate"), ("nniquad.analysis.lmi.overview", "lmis"),
                         ("nniquad.cli.commands.bound_command", "time_optimal_bound"), ("nniquad.jobs.montecarlo", "montecarlo"),
                         ("nniquad.study", "run_scenarios")):
        monkeypatch.setattr(importlib.import_module(module), name, stop)
    monkeypatch.setattr(resources, "available_memory_bytes", lambda: 16 * 2**30)


option_text = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-(10**30), max_value=10**30).map(str),
    st.sampled_from(["1e400", "-1e400", "-0", "nan", "inf", "9" * 500, "0x10", " 5", "1_000", "", "1e-320",
                     "2.5e-3", "1e6", "1e9", "0.001"]),
    st.text(max_size=12),
)

SIM_OPTIONS = ["--horizon", "--dt", "--output-dt", "--kp", "--kpy", "--Gamma", "--delta", "--noise", "--rate",
               "--seed", "--gust", "--gust-tau", "--tau-motor", "--true-mass", "--attitude-wn", "--attitude-zeta",
               "--tilt-limit"]


def _check_outcome(code: int, out: str, err: str) -> None:
    assert code in (REACHED, 0, 2), (code, err)
    assert "Traceback" not in err
    if code == 2:
        lines = [line for line in err.splitlines() if line.strip() and not line.startswith("[")]
        assert len(lines) == 1 and ": error: " in lines[0], err


@SETTINGS
@given(options=st.lists(st.tuples(st.sampled_from(SIM_OPTIONS), option_text), min_size=1, max_size=3),
       model=st.sampled_from(["linear", "reduced", "full"]), lag=st.booleans())
def test_simulate_numeric_options(run_cli, stubbed, options, model, lag):
    argv = ["simulate", "--model", model] + (["--motor-lag"] if lag else [])
    for flag, value in options:
        argv.append(f"{flag}={value}")  # '=' keeps a value such as '-5' or '' attached to its flag
    _check_outcome(*run_cli(*argv))


@SETTINGS
@given(flag=st.sampled_from(["--xi0", "--wind"]), a=option_text, b=option_text)
def test_simulate_pair_options(run_cli, stubbed, flag, a, b):
    # a value such as '-inf' reads as an option to argparse: a usage error, also one line
    _check_outcome(*run_cli("simulate", "--model", "linear", flag, a, b))


@SETTINGS
@given(options=st.lists(st.tuples(st.sampled_from(["--kp", "--kpy", "--Gamma", "--delta", "--tilt-limit-deg"]),
                                  option_text), min_size=1, max_size=3))
def test_lmi_numeric_options(run_cli, stubbed, options):
    _check_outcome(*run_cli("lmi", *(f"{f}={v}" for f, v in options)))


@SETTINGS
@given(value=option_text)
def test_bound_tilt_option(run_cli, stubbed, value):
    _check_outcome(*run_cli("bound", f"--tilt-limit-deg={value}"))


@SETTINGS
@given(options=st.lists(st.tuples(st.sampled_from(["--samples", "--seed", "--horizon", "--workers", "--batch-size",
                                                   "--worst", "--max-displacement", "--altitude-limit"]),
                                  option_text), min_size=1, max_size=3))
def test_montecarlo_numeric_options(run_cli, stubbed, options):
    _check_outcome(*run_cli("montecarlo", "--certificate", str(CERT), "--samples", "4",
                            *(f"{f}={v}" for f, v in options)))


@SETTINGS
@given(flag=st.sampled_from(["--mass-range", "--inertia-range", "--attitude-gain-range", "--tau-motor-range",
                             "--tau-motor-factor-range", "--noise-range", "--wind-range", "--wind-fraction-range"]),
       lo=st.floats(allow_nan=True, allow_infinity=True), hi=st.floats(allow_nan=True, allow_infinity=True))
def test_montecarlo_range_options(run_cli, stubbed, flag, lo, hi):
    _check_outcome(*run_cli("montecarlo", "--certificate", str(CERT), "--samples", "4", flag, repr(lo), repr(hi)))


def test_the_stub_is_reached_for_good_options(run_cli, stubbed):
    """Guard of the properties above: valid options really reach the stub (so REACHED means 'accepted')."""
    assert run_cli("simulate", "--model", "full", "--horizon", "5")[0] == REACHED
    assert run_cli("lmi")[0] == REACHED
    assert run_cli("montecarlo", "--certificate", str(CERT), "--samples", "4")[0] == REACHED


def test_a_newline_in_a_file_name_stays_one_line(run_cli, tmp_path):
    weird = tmp_path / "a\nb.json"
    weird.write_text("{")
    code, _, err = run_cli("vehicle", "--vehicle", str(weird))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "not valid JSON" in err
