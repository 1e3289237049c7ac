"""A new law is one file and one registry entry: ``tests/toy_lag_law.py`` goes through simulate, tune, certify,
verify and the command line with no edit anywhere else.

The toy law ``C(s) = c0/(tau s + 1)`` is the paper's NNI law in other coordinates (``Gamma = c0/tau``,
``delta = 1/c0``, its state ``z = c0 w``), so every number it produces has an independent reference: the NNI
law's own closed forms (its exact ZOH, its symbolic reduced loop) flown and solved on the same design.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from nniquad.analysis.cascade.box import ParameterBox
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.certificates.certificate import Certificate
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.jobs.certify import certify, verify
from nniquad.laws.nni import Gains
from nniquad.laws.registry import LAWS, law_named, register, unregister
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.sim import SimOptions, simulate
from nniquad.tuning.coordinates import tunable_law
from nniquad.tuning.tune import TuneOptions, tune
from tests.toy_lag_law import TOY_LAG, ToyLagGains

pytestmark = pytest.mark.xdist_group("new_law")

# test_certificate's design (a gain set `nniquad tune --model full` found) and its inner loops and box
NNI = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56, attitude_zeta=1.132, attitude_accel_limit_rad_s2=31.14)
BOX = ParameterBox.monte_carlo_default().scaled(0.1)


def toy_of(g: Gains) -> ToyLagGains:
    """The toy law's gains of an NNI design: ``c0 = 1/delta``, ``tau = 1/(Gamma delta)``."""
    return ToyLagGains(kp=g.kp, c0=1.0 / g.delta, tau=1.0 / (g.Gamma * g.delta))


@pytest.fixture(scope="module", autouse=True)
def toy_law():
    register(TOY_LAG)
    yield TOY_LAG
    unregister(TOY_LAG.name)


def test_the_law_is_registered_and_asks_nothing_more():
    assert law_named("toy_lag") is TOY_LAG and list(LAWS)[-1] == "toy_lag"
    g = toy_of(NNI)
    assert g.law is TOY_LAG and TOY_LAG.ni_structure and TOY_LAG.sim_state_names == ("zc_x", "zc_y")
    # the sector constant by hand: C(0)/(m kp) = c0/(m kp) = 1/(m kp delta)
    assert TOY_LAG.sector_constant(g, V.m) == pytest.approx(1.0 / (V.m * NNI.kp * NNI.delta), rel=1e-14)
    # the start state is the law's static state for the position (w = xi): from the interface, not written here
    np.testing.assert_allclose(TOY_LAG.start_state(g, V.m, (2.0, -1.5)), [2.0, -1.5], rtol=1e-14)


@pytest.mark.parametrize("model, sampling", [("linear", "continuous"), ("linear", "discrete"), ("full", "discrete")])
def test_it_flies_as_the_nni_law_it_is(model, sampling):
    """Same trajectory as the NNI law from the state that matches (``z(0) = c0 w(0) = c0 xi(0)``), although the
    simulator builds the toy law from its realisation (and its discrete step from the generic matrix exponential)
    and the NNI law from its own closed forms."""
    g = toy_of(NNI)
    opts = SimOptions(model=model, horizon_s=4.0, controller_sampling=sampling, motor_lag=model == "full",
                      inner=INNER)
    toy = simulate(V, g, opts)[0]
    ref = simulate(V, NNI, opts.with_(zc0=(g.c0 * opts.xi0[0], g.c0 * opts.xi0[1])))[0]
    np.testing.assert_allclose(toy.xy, ref.xy, rtol=0, atol=1e-9)
    np.testing.assert_allclose(g.c0 * toy.z_c, ref.z_c, rtol=1e-9, atol=1e-9)


def test_its_reduced_loop_is_the_nni_loop():
    """One reduced loop over the law's realisation: the poles and the exact Routh verdict of the toy law's loop are
    those of the NNI law's symbolic loop."""
    toy, ref = ReducedLoop.from_vehicle(V, toy_of(NNI)), ReducedLoop.from_vehicle(V, NNI)
    assert toy.stable and ref.stable
    np.testing.assert_allclose(np.sort_complex(toy.poles_and_damping().poles),
                               np.sort_complex(ref.poles_and_damping().poles), rtol=1e-9)
    assert toy.smallest_gamma == pytest.approx(ref.smallest_gamma, rel=1e-13)
    assert toy.sector_limit(0.8) == ("c0_max", pytest.approx(0.8 * V.m * NNI.kp, rel=1e-14))


def test_it_tunes_under_its_sector_bound():
    res = tune(V, TuneOptions(model="reduced", budget="quick", controller="toy_lag", reruns=0))
    g = res.gains
    assert isinstance(g, ToyLagGains) and math.isfinite(res.settling_s)
    assert g.c0 / (V.m * g.kp) <= 0.8 * (1 + 1e-12)  # gamma <= gamma_max, by hand
    law = tunable_law("toy_lag")
    back = law.decode(law.encode(g, V.m, 0.8), V.m, 0.8)  # the coordinates map back to the gains
    assert all(math.isclose(back.values()[k], v, rel_tol=1e-12) for k, v in g.values().items())


@pytest.mark.slow  # a certificate with its cascade section
def test_it_certifies_and_verifies(tmp_path):
    cert = certify(V, toy_of(NNI), inner=INNER, options=TuneOptions(model="full", controller="toy_lag"), box=BOX)
    doc = cert.to_json()
    assert doc["gains"] == {"controller": "toy_lag", **toy_of(NNI).values()}
    assert set(doc["sector"]) == {"gamma", "gamma_max", "c0_max"}
    assert doc["sector"]["gamma"] == pytest.approx(1.0 / (V.m * NNI.kp * NNI.delta), rel=1e-12)
    assert doc["cascade"]["model"].endswith("motors, controller)")  # 19 states, the law's own name for its part
    path = cert.write(tmp_path / "toy.json")
    again = Certificate.read(path)
    assert again.gains == toy_of(NNI) and again.digest == cert.digest
    assert verify(again).ok
    # the certified closed loop is the NNI design's: the stated poles are the NNI reduced loop's
    stated = np.array([complex(re, im) for re, im in doc["stability_margin"]["poles_1_s"]])
    np.testing.assert_allclose(np.sort_complex(stated),
                               np.sort_complex(ReducedLoop.from_vehicle(V, NNI).poles_and_damping().poles), rtol=1e-9)


def test_the_command_line_takes_it(run_cli, tmp_path):
    g = toy_of(NNI)
    out = tmp_path / "run.json"
    code, _, err = run_cli("simulate", "--controller", "toy_lag", "--kp", repr(g.kp), "--c0", repr(g.c0), "--tau",
                           repr(g.tau), "--model", "linear", "--horizon", "5", "--json", str(out))
    assert code == 0, err
    assert json.loads(out.read_text())["gains"] == g.as_dict()
    code, out_text, _ = run_cli("tune", "--help")
    assert code == 0 and "toy_lag" in out_text and "--c0" in run_cli("certify", "--help")[1]
    code, _, err = run_cli("simulate", "--controller", "toy_lag", "--kp", "3")
    assert code == 2 and "--c0" in err and len(err.strip().splitlines()) == 1
