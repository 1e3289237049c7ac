"""The filtered-derivative PD law is the NNI law: the maps, and the same run to round-off.

Independent references: the two laws' transfer functions evaluated by hand in numpy (not the map's
formulas), and the simulator running each law with its own state equation (the PD filter state ``d``
with its own discrete step, the NNI state ``z`` with :class:`DiscreteNNI`'s), from the same start.
"""

from __future__ import annotations

import numpy as np
import pytest

from nniquad.laws.nni import Gains
from nniquad.laws.pd_filtered import PDFilteredGains
from nniquad.laws.pd_filtered import (filtered_pd_from_nni, filtered_pd_gamma, filtered_pd_in_sector,
                                            nni_from_filtered_pd, nni_start_state)
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.errors import GainError
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.sim import SimOptions, simulate

# the tuned filtered PD of the speed study (`nniquad tune --model full --controller pd_filtered`), and its inner loops
PD = PDFilteredGains(kp=9.111984627754474, kd=4.426807306344244, tau_f=0.05246651970835971)


def _pd_response(pd: PDFilteredGains, w: np.ndarray) -> np.ndarray:
    s = 1j * w
    return -pd.kp - pd.kd * s / (pd.tau_f * s + 1.0)


def _nni_response(g: Gains, m: float, w: np.ndarray) -> np.ndarray:
    s = 1j * w
    return -g.kp + (g.Gamma / (s + g.Gamma * g.delta)) / m


def test_the_image_has_the_same_frequency_response():
    g = nni_from_filtered_pd(PD, V.m)
    w = np.geomspace(1e-3, 1e4, 200)
    np.testing.assert_allclose(_nni_response(g, V.m, w), _pd_response(PD, w), rtol=1e-12)
    # another mass gives another NNI law for the same PD: the map uses the controller's mass
    other = nni_from_filtered_pd(PD, 2 * V.m)
    assert np.max(np.abs(_nni_response(other, V.m, w) - _pd_response(PD, w))) > 1.0


def test_maps_are_inverse_and_the_inverse_exists_exactly_when_the_reduced_loop_is_stable():
    g = nni_from_filtered_pd(PD, V.m)
    back = filtered_pd_from_nni(g, V.m)
    for k in ("kp", "kd", "tau_f"):
        assert getattr(back, k) == pytest.approx(getattr(PD, k), rel=1e-12)
    g2 = Gains(kp=19.0, Gamma=43.9, delta=0.1317)
    again = nni_from_filtered_pd(filtered_pd_from_nni(g2, V.m), V.m)
    assert (again.kp, again.Gamma, again.delta) == pytest.approx((g2.kp, g2.Gamma, g2.delta), rel=1e-12)
    # m kp delta <= 1 (unstable reduced loop): no filtered PD; just above 1 a tiny k_p
    crit = 1.0 / (V.m * 10.0)
    assert not ReducedLoop.from_vehicle(V, Gains(kp=10.0, Gamma=5.0, delta=crit * 0.999)).poles_and_damping().stable
    with pytest.raises(GainError, match="m kp delta"):
        filtered_pd_from_nni(Gains(kp=10.0, Gamma=5.0, delta=crit * 0.999), V.m)
    assert 0 < filtered_pd_from_nni(Gains(kp=10.0, Gamma=5.0, delta=crit * 1.001), V.m).kp < 0.02
    with pytest.raises(GainError, match="kpy"):
        filtered_pd_from_nni(Gains(kp=10.0, Gamma=5.0, delta=1.0, kpy=11.0), V.m)
    with pytest.raises(GainError):
        nni_from_filtered_pd(g, V.m)  # not a filtered PD block


def test_sector_gamma_of_a_filtered_pd():
    """The smallest sector gamma of the image (the reduced loop's own computation) equals k_d/(k_p tau_f + k_d)."""
    g = nni_from_filtered_pd(PD, V.m)
    gamma = ReducedLoop.from_vehicle(V, g).smallest_gamma
    assert filtered_pd_gamma(PD) == pytest.approx(gamma, rel=1e-12)
    assert 0.8 < gamma < 1.0  # the tuned PD lies outside the paper's gamma = 0.8, inside gamma < 1
    assert not filtered_pd_in_sector(PD, 0.8) and filtered_pd_in_sector(PD, 0.95)
    # exactly on the bound: k_p tau_f / k_d = 1/gamma_max - 1
    on = PDFilteredGains(kp=0.25 * 4.0 / 0.05, kd=4.0, tau_f=0.05)
    assert filtered_pd_in_sector(on, 0.8) and not filtered_pd_in_sector(PDFilteredGains(4.9, 4.0, 0.05), 0.8)


def _pair(model: str, sampling: str, noise: float = 0.0):
    o = SimOptions(model=model, horizon_s=6.0, output_dt_s=0.005, motor_lag=model == "full", noise_sigma_m=noise,
                   controller_sampling=sampling, noise_rate_hz=100.0)
    g = nni_from_filtered_pd(PD, V.m)
    pd_run = simulate(V, PD, o)[0]
    nni_run = simulate(V, g, o.with_(zc0=nni_start_state(PD, V.m, o.xi0)))[0]
    return pd_run, nni_run, o, g


@pytest.mark.parametrize("model", ["reduced", "full"])
@pytest.mark.parametrize("sampling", ["continuous", "held", "discrete"])
def test_the_two_laws_give_the_same_run_to_round_off(model, sampling):
    """From the same start (z(0) = d(0)/delta), the PD law and its NNI image give the same trajectory, command
    and controller state (z = d/delta) to round-off: reduced and full model, continuous, held and discrete
    controller (the discrete one with position noise, so every sample matters)."""
    pd_run, nni_run, o, g = _pair(model, sampling, noise=0.01 if sampling == "discrete" else 0.0)
    scale = float(np.max(np.abs(pd_run.xy)))
    assert scale > 1.0  # the run goes somewhere
    np.testing.assert_allclose(nni_run.xy, pd_run.xy, rtol=0, atol=1e-11 * scale)
    np.testing.assert_allclose(nni_run.a_cmd, pd_run.a_cmd, rtol=0, atol=1e-9)
    np.testing.assert_allclose(nni_run.z_c * g.delta, pd_run.z_c, rtol=0, atol=1e-11 * scale)
    assert nni_run.metrics().settling_s == pytest.approx(pd_run.metrics().settling_s, abs=1e-9)
    if sampling == "discrete":  # the discrete runs are not the continuous ones
        cont = simulate(V, PD, o.with_(controller_sampling="continuous", noise_sigma_m=0.0))[0]
        assert np.max(np.abs(cont.xy - pd_run.xy)) > 1e-3


def test_another_start_gives_another_run():
    """The controller state matters: the image started at z = 0 (the paper's start) is a different run.

    From 2 cm (inside the tilt limit's linear zone) the first command is -k_p' xi(0) against -k_p xi(0)."""
    o = SimOptions(model="reduced", horizon_s=3.0, output_dt_s=0.005, xi0=(0.02, 0.0))
    g = nni_from_filtered_pd(PD, V.m)
    a = simulate(V, PD, o)[0]
    b = simulate(V, g, o)[0]
    assert a.a_cmd[0, 0] == pytest.approx(-PD.kp * 0.02, rel=1e-12)
    assert b.a_cmd[0, 0] == pytest.approx(-g.kp * 0.02, rel=1e-12)
    assert np.max(np.abs(a.xy - b.xy)) > 1e-3
