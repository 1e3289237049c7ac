"""``--rate`` on ``simulate`` and ``certify``: the control rate reaches the simulator and the certificate.

References: the library's own discrete-controller run (``SimOptions(controller_sampling="discrete")``,
itself checked against DiscreteNNI in tests/test_simulate_discrete.py) and ``nniquad verify``,
which re-simulates the certificate's runs from their recorded settings.
"""

from __future__ import annotations

import inspect
import json
import re

import numpy as np
import pytest

from nniquad.certificates import read_certificate
from nniquad.config import CONTROL_RATE_HZ
from nniquad.laws.nni import Gains
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.sim import SimOptions, simulate
from tests.test_honest_word import assert_no_contradiction

GAINS = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56, attitude_zeta=1.132, attitude_accel_limit_rad_s2=31.14)


@pytest.mark.parametrize("args, sampling, rate", [
    ([], "continuous", CONTROL_RATE_HZ),
    (["--rate", "50"], "discrete", 50.0),
    (["--noise", "0.001"], "discrete", CONTROL_RATE_HZ),
    (["--rate", "50", "--sampling", "held"], "held", 50.0),
])
def test_simulate_rate_is_the_control_rate(run_cli, tmp_path, args, sampling, rate):
    js = tmp_path / "r.json"
    code, out, err = run_cli("simulate", "--model", "reduced", "--horizon", "4", "--kp", "3", "--Gamma", "2",
                             "--delta", "1", "--json", str(js), *args)
    assert code == 0, err
    doc = json.loads(js.read_text())
    assert doc["options"]["controller_sampling"] == sampling and doc["options"]["noise_rate_hz"] == rate
    noise = 0.001 if "--noise" in args else 0.0
    ref = simulate(V, Gains(3.0, 2.0, 1.0), SimOptions(model="reduced", horizon_s=4.0, controller_sampling=sampling,
                                                        noise_rate_hz=rate, noise_sigma_m=noise))[0]
    with np.load(doc["trajectory"]) as t:
        np.testing.assert_array_equal(t["state"], ref.state)


@pytest.mark.parametrize("args, message", [
    (["--rate", "0"], "rate must be positive"),
    (["--rate", "inf"], "rate must be positive"),
    (["--rate", "300"], "whole multiple"),
    (["--rate", "2000"], "exceeds"),
    (["--rate", "50", "--sampling", "continuous"], "cannot be used with --sampling continuous"),
])
def test_simulate_bad_rate(run_cli, args, message):
    code, out, err = run_cli("simulate", "--model", "linear", "--horizon", "1", *args)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err


# the test design tolerates only a slightly slower motor: a tenth of the Monte Carlo box (log scale)


def _small_box():
    from nniquad.analysis.cascade.box_certificate import ParameterBox

    return ParameterBox.monte_carlo_default().scaled(0.1)


def test_build_certificate_takes_the_rate():
    from nniquad.certificates.build import build_certificate

    assert inspect.signature(build_certificate).parameters["rate_hz"].default == CONTROL_RATE_HZ


@pytest.mark.slow  # a whole certificate at 50 Hz
def test_build_certificate_rate_reaches_margins_and_the_sampled_full_run():
    from nniquad.certificates.build import build_certificate

    cert = build_certificate(V, GAINS, inner=INNER, model="full", rate_hz=50.0, box=_small_box()).to_json()
    assert cert["margins"]["rate_hz"] == 50.0
    full, reduced = cert["performance"]["full"]["settings"], cert["performance"]["reduced"]["settings"]
    assert full["controller_sampling"] == "discrete" and full["noise_rate_hz"] == 50.0
    assert "controller_sampling" not in reduced and reduced["sample_hold"] is None  # the paper's continuous loop
    # the stated full run is the discrete-controller run at 50 Hz, re-simulated from its settings
    opts = SimOptions(**{**{k: v for k, v in full.items() if k != "inner"}, "xi0": tuple(full["xi0"]),
                         "zc0": tuple(full["zc0"]), "wind_N": tuple(full["wind_N"]), "inner": INNER})
    met = simulate(V, GAINS, opts)[0].metrics()
    assert cert["performance"]["full"]["settling_s"] == pytest.approx(met.settling_s, rel=1e-9)
    cont = simulate(V, GAINS, opts.with_(controller_sampling=None, sample_hold=None))[0].metrics()
    assert abs(cont.settling_s - met.settling_s) > 1e-3


@pytest.mark.xdist_group("small_certificate")  # test_certificate's design: built once, on its worker
def test_certify_rate_reaches_the_margins(run_cli, tmp_path):
    """certify --rate 100 (the default; verify accepts another rate only with a cascade section that states it)."""
    out_path = tmp_path / "c.json"
    code, out, err = run_cli("certify", "--kp", str(GAINS.kp), "--Gamma", str(GAINS.Gamma), "--delta",
                             str(GAINS.delta), "--attitude-wn", "101.56", "--attitude-zeta", "1.132",
                             "--attitude-accel", "31.14", "--model", "full", "--rate", "100", "--box-scale", "0.1",
                             "--out", str(out_path))
    assert code == 0, err
    assert json.loads(out_path.read_text())["margins"]["rate_hz"] == 100.0
    # the progress lines show real percentages: one per step, rising, ending at 100
    percents = [int(p) for p in re.findall(r"^\[certify +[\d.]+ s\] +(\d+) %", err, re.M)]
    assert len(percents) >= 6 and percents == sorted(set(percents)) and percents[0] == 0 and percents[-1] == 100, err
    # what certify printed about the start: one word, no two lines that contradict each other
    assert_no_contradiction([line.strip() for line in out.splitlines()], read_certificate(out_path))
    code, out, err = run_cli("verify", str(out_path))
    assert code == 0, out + err


@pytest.mark.parametrize("value, message", [("0", "positive"), ("nan", "positive"), ("300", "whole multiple")])
def test_certify_bad_rate(run_cli, tmp_path, value, message):
    out_path = tmp_path / "c.json"
    code, out, err = run_cli("certify", "--kp", "13", "--Gamma", "25", "--delta", "0.19", "--rate", value,
                             "--out", str(out_path))
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not out_path.exists()
