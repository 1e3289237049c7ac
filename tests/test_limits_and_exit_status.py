"""Resource estimates, the RK4 step bound of the inner loops, and the one exit-status scheme of the CLI."""

from __future__ import annotations

import json
import math
import os
import signal
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from nniquad.config import RK4_STEP_LIMIT
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.errors import (EXIT_CHECK_FAILED, EXIT_INTERNAL_ERROR, EXIT_INTERRUPTED, EXIT_TERMINATED,
                            EXIT_USER_ERROR, ResourceError, SimulationError, Terminated)
from nniquad.resources import (MODEL_SIZES, Estimate, available_memory_bytes, check_estimate, montecarlo_estimate,
                               simulation_estimate)
from nniquad.validate import check_rk4_step, inner_loop_poles

CERT = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"


# ============================================================================ memory and time


def test_model_sizes_match_the_simulator():
    from nniquad.resources import EXO_COLUMNS
    from nniquad.sim import EXO_FIELDS, OUTPUT_NAMES, STATE_NAMES

    assert MODEL_SIZES == {m: (len(STATE_NAMES[m]), len(OUTPUT_NAMES[m])) for m in STATE_NAMES}
    assert EXO_COLUMNS == len(EXO_FIELDS)


@pytest.mark.parametrize("model", ["linear", "full"])
def test_memory_estimate_equals_the_arrays_a_run_allocates(model):
    """The formula against the arrays a real run holds: states + outputs per sample, the exogenous inputs per step."""
    from nniquad.laws.nni import PAPER_GAINS
    from nniquad.model.vehicle import PAPER_VEHICLE
    from nniquad.sim import SimOptions, exogenous_inputs, simulate

    opts = SimOptions(model=model, horizon_s=0.5)
    traj = simulate(PAPER_VEHICLE, PAPER_GAINS, opts)[0]
    actual = traj.state.nbytes + traj.outputs.nbytes + exogenous_inputs(opts).nbytes
    assert simulation_estimate(model, 0.5, opts.dt_s, opts.output_dt_s).memory_bytes == actual


def test_the_issue_numbers():
    # horizon 1e6 s on the full model: the exogenous array alone is 1e9 steps x 11 x 8 B = 82 GiB, and
    # 1e8 output samples of 21 states and 12 outputs (the rotor commands of issue 44 included) x 8 B = 24.6 GiB:
    # 106.5 GiB
    est = simulation_estimate("full", 1e6, 1e-3, 1e-2)
    assert est.memory_bytes >= 1e9 * 11 * 8 and est.memory_bytes / 2**30 == pytest.approx(106.5, abs=0.1)
    assert simulation_estimate("full", 1e9, 1e-3, 1e-2).memory_bytes >= 36 * 2**40
    assert montecarlo_estimate(10**12, 20.0, 1e-3, 1e-2, 2).memory_bytes > 2**50


def test_check_estimate_limits():
    small = Estimate("x", memory_bytes=1e6, seconds=1.0)
    assert check_estimate(small, option="--x", available_bytes=2**30) is small
    with pytest.raises(ResourceError, match=r"--x: .*needs about 1.86 GiB .* 1 GiB available"):
        check_estimate(Estimate("x", 2e9, 1.0), option="--x", available_bytes=2**30)
    with pytest.raises(ResourceError, match="more than the 30 days"):
        check_estimate(Estimate("x", 1.0, 1e9), option="--x", available_bytes=2**30)


def test_available_memory_is_the_machines():
    physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    assert 0 < available_memory_bytes() <= physical


# ============================================================================ RK4 step bound


def _rk4_amplification(z: complex) -> float:
    return abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)


def test_rk4_bound_is_inside_the_stability_region():
    """|z| <= RK4_STEP_LIMIT is stable in every left-half-plane direction (the claim the check rests on)."""
    angles = np.linspace(np.pi / 2, np.pi, 721)
    radii = np.linspace(1e-3, RK4_STEP_LIMIT, 400)
    worst = max(_rk4_amplification(r * np.exp(1j * a)) for a in angles for r in radii)
    assert worst <= 1.0 + 1e-12
    assert _rk4_amplification(-2.8) > 1  # and the real-axis limit 2.785 is right beyond it


def test_inner_loop_poles_are_the_roots_of_the_loop_polynomials():
    inner = InnerLoopGains(attitude_wn_rad_s=40.0, attitude_zeta=1.7, attitude_gain_scale=1.3)
    poles = inner_loop_poles(inner, tau_motor_s=0.01)
    s = 1.3
    expected = max(abs(r) for r in np.roots([1.0, 2 * 1.7 * 40.0 * s, s * 40.0**2]))
    assert poles["attitude"] == pytest.approx(expected)
    assert poles["yaw"] == pytest.approx(max(abs(r) for r in np.roots([1.0, 2 * 0.8 * 8.0 * s, s * 64.0])))
    assert poles["altitude"] == 3.0 and poles["motor lag"] == 100.0


def test_step_check_accepts_the_defaults_and_refuses_the_fast_loop():
    check_rk4_step(inner_loop_poles(DEFAULT_INNER_LOOP_GAINS, tau_motor_s=0.005), 1e-3)
    wn = RK4_STEP_LIMIT / 1e-3  # a complex pair of modulus wn sits exactly on the bound
    check_rk4_step(inner_loop_poles(InnerLoopGains(attitude_wn_rad_s=wn * (1 - 1e-9))), 1e-3)
    with pytest.raises(SimulationError, match="attitude pole"):
        check_rk4_step(inner_loop_poles(InnerLoopGains(attitude_wn_rad_s=wn * (1 + 1e-9))), 1e-3,
                       error=SimulationError)


def test_python_api_refuses_a_pole_faster_than_the_step(run_cli):
    """simulate() itself refuses the loop the CLI refuses, at the bound of the closed-form pole, in the same words."""
    from nniquad.errors import NniquadError
    from nniquad.model.vehicle import PAPER_VEHICLE
    from nniquad.sim import SimOptions, SimParams, simulate

    dt, zeta = 1e-3, 0.8
    wn = RK4_STEP_LIMIT / dt  # a complex pair lambda^2 + 2 zeta wn lambda + wn^2 has modulus wn (hand derivation)
    too_fast = SimOptions(model="full", horizon_s=0.02, dt_s=dt,
                          inner=InnerLoopGains(attitude_wn_rad_s=wn * (1 + 1e-6), attitude_zeta=zeta))
    with pytest.raises(SimulationError, match="attitude pole") as info:
        simulate(PAPER_VEHICLE, None, too_fast)
    assert isinstance(info.value, NniquadError)
    modulus = max(abs(r) for r in np.roots([1.0, 2 * zeta * wn * (1 + 1e-6), (wn * (1 + 1e-6)) ** 2]))
    assert f"|lambda| = {modulus:.4g} 1/s" in str(info.value)
    just_inside = too_fast.with_(inner=InnerLoopGains(attitude_wn_rad_s=wn * (1 - 1e-6), attitude_zeta=zeta))
    assert np.all(np.isfinite(simulate(PAPER_VEHICLE, None, just_inside)[0].state))
    # ready parameter sets (the Monte Carlo and tuner path) meet the same check: the motor pole 1/tau
    lagged = SimOptions(model="full", horizon_s=0.02, dt_s=dt, motor_lag=True)
    params = SimParams.from_options(PAPER_VEHICLE, (5.0, 160.0, 0.6), lagged)
    with pytest.raises(SimulationError, match="motor lag pole"):
        simulate(None, None, lagged, params=params.with_(plant={"tau_motor": dt / (RK4_STEP_LIMIT * (1 + 1e-6))}))
    simulate(None, None, lagged, params=params.with_(plant={"tau_motor": dt / (RK4_STEP_LIMIT * (1 - 1e-6))}))
    # the command line turns the same error into its one line, exit status 2, naming its own option
    code, out, err = run_cli("simulate", "--model", "full", "--horizon", "0.02", "--attitude-wn", f"{wn * 1.01!r}")
    api = str(pytest.raises(SimulationError, simulate, PAPER_VEHICLE, None,
                            too_fast.with_(inner=InnerLoopGains(attitude_wn_rad_s=wn * 1.01))).value)
    lines = err.strip().splitlines()
    assert code == EXIT_USER_ERROR and out == "" and len(lines) == 1
    assert lines[0].startswith("nniquad simulate: error: " + api.split("; change")[0] + "; change --attitude-wn")


def test_montecarlo_api_refuses_ranges_too_fast_for_the_step_before_any_scenario():
    import nniquad
    from nniquad.errors import MonteCarloError
    from nniquad.study import DEFAULT_RANGES

    ran = []
    with pytest.raises(MonteCarloError, match="attitude pole .*ScenarioRanges.attitude_gain_factor"):
        nniquad.montecarlo(CERT, 4, ranges=DEFAULT_RANGES.with_(attitude_gain_factor=(1.0, 1e4)), workers=1,
                           progress=lambda done, total: ran.append(done))
    assert ran == []


# ============================================================================ exit status


def test_help_documents_the_scheme(run_cli):
    for argv in (["--help"], ["verify", "--help"], ["montecarlo", "--help"]):
        code, out, _ = run_cli(*argv)
        assert code == 0
        text = " ".join(out.split())
        assert "exit status: 0" in text and "1 a check failed" in text and "2 user error" in text
        assert "130 interrupted" in text
        assert "143 terminated (SIGTERM" in text


def test_readme_documents_the_scheme():
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    for code in ("| 0 |", "| 1 |", "| 2 |", "| 3 |", "| 130 |", "| 143 |"):
        assert code in readme
    # the same statuses wherever they are documented: the module docstring of the CLI and every --help
    import importlib

    cli_main = importlib.import_module("nniquad.cli.main")
    for status in (EXIT_INTERRUPTED, EXIT_TERMINATED):
        assert f"\n    {status}  " in cli_main.__doc__ and f" {status} " in cli_main.EXIT_STATUS_HELP
    assert EXIT_TERMINATED == 128 + signal.SIGTERM and EXIT_INTERRUPTED == 128 + signal.SIGINT  # the shell's rule


def test_verify_exit_status(run_cli, tmp_path):
    text = CERT.read_text()
    tampered = tmp_path / "t.json"
    tampered.write_text(text.replace('"tilt_limit_deg": 30.0', '"tilt_limit_deg": 30.5', 1))
    code, _, err = run_cli("verify", str(tampered), "--no-simulate")
    assert code == EXIT_CHECK_FAILED and "digest mismatch" in err
    broken = tmp_path / "b.json"
    broken.write_text(text[:100])
    assert run_cli("verify", str(broken))[0] == EXIT_USER_ERROR
    assert run_cli("verify", str(CERT), "--no-simulate")[0] == 0


@pytest.mark.parametrize("exc, code, word", [
    (KeyboardInterrupt(), EXIT_INTERRUPTED, "interrupted"),
    (Terminated(), EXIT_TERMINATED, "terminated"),
    (MemoryError(), EXIT_USER_ERROR, "not enough memory"),
    (RecursionError(), EXIT_USER_ERROR, "nested too deeply"),
    (OSError(28, "No space left on device", "out.json"), EXIT_USER_ERROR, "out.json: No space left"),
    (PermissionError(13, "Permission denied", "/x/y"), EXIT_USER_ERROR, "Permission denied"),
    (RuntimeError("a bug"), EXIT_INTERNAL_ERROR, "internal error"),
])
def test_main_maps_every_failure_to_its_status(run_cli, monkeypatch, exc, code, word):
    import nniquad.cli.commands.vehicle_command as vehicle_cmd

    def boom(args):
        raise exc

    monkeypatch.setattr(vehicle_cmd, "run", boom)
    rc, _, err = run_cli("vehicle")
    assert rc == code and word in err
    lines = [line for line in err.splitlines() if line.startswith("nniquad")]
    assert len(lines) == 1
    assert ("Traceback" in err) == (code == EXIT_INTERNAL_ERROR)  # only a bug shows one


# ---------------------------------------------------------------------------- SIGTERM, like Ctrl-C


def _sigterm_self_then_wait():
    # never SIGTERM the test runner itself unless nniquad's handler is there to catch it
    assert signal.getsignal(signal.SIGTERM) not in (signal.SIG_DFL, signal.SIG_IGN, None)
    os.kill(os.getpid(), signal.SIGTERM)
    for _ in range(200):  # the handler runs between bytecodes: within the first few iterations
        time.sleep(0.01)
    raise AssertionError("SIGTERM raised nothing")


def test_sigterm_during_a_command_ends_it_cleanly_with_143(run_cli, monkeypatch, tmp_path):
    """A real SIGTERM mid-write: the temporary file is removed, one line, exit 143, the old handler back."""
    import nniquad.cli.commands.vehicle_command as vehicle_cmd
    from nniquad.io import atomic_write_with

    def writer(tmp):
        tmp.write_text("half a file")
        _sigterm_self_then_wait()

    monkeypatch.setattr(vehicle_cmd, "run", lambda args: atomic_write_with(tmp_path / "out.json", writer))
    before = signal.getsignal(signal.SIGTERM)
    rc, out, err = run_cli("vehicle")
    assert rc == EXIT_TERMINATED and err.strip() == "nniquad vehicle: terminated"
    assert list(tmp_path.iterdir()) == []  # neither the file nor its temporary
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_swallowed_sigterm_still_ends_the_command_with_143(run_cli, monkeypatch):
    """CasADi clears the exception a signal raises inside its loops (IPOPT then fails): the request is sticky."""
    import nniquad.cli.commands.vehicle_command as vehicle_cmd
    from nniquad.errors import SolverError
    from nniquad.progress import Progress

    def solver_fails(args):
        try:
            _sigterm_self_then_wait()
        except Terminated:  # what CasADi does: the exception is gone, the solve fails
            pass
        raise SolverError("IPOPT failed on the bound problem: NonIpopt_Exception_Thrown")

    after_progress = []

    def carries_on(args):
        try:
            _sigterm_self_then_wait()
        except Terminated:
            pass
        Progress("vehicle", enabled=False).message("next stage")  # the next progress report raises it again
        after_progress.append(True)

    for run, dropped in ((solver_fails, "IPOPT"), (carries_on, "Traceback")):
        monkeypatch.setattr(vehicle_cmd, "run", run)
        rc, out, err = run_cli("vehicle")
        assert rc == EXIT_TERMINATED and err.strip() == "nniquad vehicle: terminated", err
        assert dropped not in err
    assert after_progress == []
    # the request ends with the command: the next one runs normally
    monkeypatch.setattr(vehicle_cmd, "run", lambda args: 0)
    assert run_cli("vehicle")[0] == 0


def test_sigterm_on_a_real_simulate_leaves_no_file(tmp_path):
    """A real process: SIGTERM once the run has started (its progress line), exit 143, no output, no traceback."""
    from test_montecarlo_faults import signal_when_ready

    cmd = [sys.executable, "-m", "nniquad", "simulate", "--horizon", "3000", "--json", "s.json", "--plot", "s.png"]
    code, out, lines = signal_when_ready(cmd, tmp_path, lambda line: "3000 s simulated" in line,
                                         lambda proc: proc.send_signal(signal.SIGTERM))
    err = "".join(lines)
    assert code == EXIT_TERMINATED, err
    assert "Traceback" not in err and err.strip().splitlines()[-1] == "nniquad simulate: terminated"
    assert list(tmp_path.iterdir()) == []


def test_usage_errors_are_one_line(run_cli):
    code, _, err = run_cli("simulate", "--horizon", "soon")
    assert code == EXIT_USER_ERROR and len(err.strip().splitlines()) == 1 and "invalid float value" in err


def test_json_output_is_still_written(run_cli, tmp_path):
    out = tmp_path / "v.toml"
    code, _, _ = run_cli("vehicle", "--write", str(out))
    assert code == 0 and out.is_file()
    code, _, _ = run_cli("bound", "--json", str(tmp_path / "deep" / "b.json"))
    assert code == 0 and json.loads((tmp_path / "deep" / "b.json").read_text())["enter_band_s"] > 0
    assert math.isfinite(json.loads((tmp_path / "deep" / "b.json").read_text())["a_max_m_s2"])
