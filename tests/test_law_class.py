"""Law classes: the paper class keeps the sector bound, the cascade class drops it and is
certified by the sampled-data cascade alone; the tuner searches each class in its own coordinates, ranks the
discrete controller at the control rate, and is seeded with filtered PDs through their NNI image.

Independent references: the sector constant recomputed by :class:`ReducedLoop` (not the coordinates' formulas),
the filtered PD's sector region by hand (k_p tau_f/k_d >= 1/gamma_max - 1), a direct discrete simulation for the
tuner's cost, and ``verify`` recomputing a certificate whose law class was edited and re-signed.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.analysis.cascade.box_certificate import ParameterBox
from nniquad.certificates import build_certificate, canonical_digest, verify_certificate
from nniquad.laws.nni import Gains
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.laws.pd_filtered import PDFilteredGains
from nniquad.laws.classes import LAW_CLASSES
from nniquad.laws.pd_filtered import filtered_pd_in_sector, nni_from_filtered_pd
from nniquad.errors import CertificateError, NniquadError
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.tuning.coordinates import decode, encode, search_box, warm_start_coordinates
from nniquad.tuning.vehicle_limits import gain_limits
from nniquad.tuning.coordinates import tunable_law as law_of
from nniquad.tuning.tune_options import TuneOptions

# the tuned filtered PD of the speed study and its inner loops (notebooks/data/designs/pd_filtered_held.json):
# outside gamma = 0.8
PD = PDFilteredGains(kp=9.111984627754474, kd=4.426807306344244, tau_f=0.05246651970835971)
PD_INNER = InnerLoopGains(attitude_wn_rad_s=20.499630377601115, attitude_zeta=0.8199852151040445,
                          attitude_accel_limit_rad_s2=29.867503481638387)
IMAGE = nni_from_filtered_pd(PD, V.m)
SMALL_BOX = ParameterBox.monte_carlo_default().scaled(0.1)

#: One xdist worker runs this module: its cascade-class certificate is built once, and no other worker waits for it.
pytestmark = pytest.mark.xdist_group("law_class")


def test_options_resolve_the_class():
    assert TuneOptions().law_class == "paper" and TuneOptions().roa_radius_m == pytest.approx(2.5)
    c = TuneOptions(model="full", law_class="cascade")
    assert c.roa_radius_m == 0.0 and c.require_margins  # the reduced loop's reach is the paper class's statement
    assert TuneOptions(law_class="cascade", roa_radius_m=1.0).roa_radius_m == 1.0
    assert TuneOptions(controller="pd_filtered").law_class is None
    pdc = TuneOptions(model="full", controller="pd_filtered", law_class="paper")
    assert pdc.require_margins and pdc.nni_image and pdc.roa_radius_m == 0.0
    assert not TuneOptions(model="full", controller="pd_filtered").require_margins
    with pytest.raises(NniquadError, match="law class must be"):
        TuneOptions(law_class="sector")
    with pytest.raises(NniquadError, match="no law class"):
        TuneOptions(controller="pd_velocity", law_class="paper")
    assert TuneOptions(model="full").rate_hz == 100.0


def test_cascade_coordinates_put_the_routh_condition_in_the_box():
    """v = ln(m kp delta - 1): gamma = 1/(1 + e^v) by the reduced loop's own computation, down to the cap."""
    options = TuneOptions(model="reduced", law_class="cascade")
    lo, hi = search_box(options, vehicle=V)
    assert 1.0 / (1.0 + math.exp(lo[1])) == pytest.approx(0.995, rel=1e-12)
    assert 1.0 / (1.0 + math.exp(lo[1])) > 0.8 > 1.0 / (1.0 + math.exp(hi[1]))  # the paper class lies inside
    rng = np.random.default_rng(7)
    for q in lo + rng.random((40, 3)) * (hi - lo):
        g, _ = decode(q, V.m, 0.8, law_class="cascade")
        assert ReducedLoop.from_vehicle(V, g).smallest_gamma == pytest.approx(1 / (1 + math.exp(q[1])), rel=1e-12)
        assert ReducedLoop.from_vehicle(V, g).poles_and_damping().stable
        np.testing.assert_allclose(encode(g, V.m, 0.8, law_class="cascade"), q, rtol=1e-12, atol=1e-12)
    # the tuned filtered PD's image is a point of the cascade box, not of the paper box
    q = encode(IMAGE, V.m, 0.8, law_class="cascade")
    assert np.all(q >= lo) and np.all(q <= hi)
    qp = encode(IMAGE, V.m, 0.8, law_class="paper")
    plo, _ = search_box(TuneOptions(model="reduced"), vehicle=V)
    assert qp[1] < plo[1]  # u < 0: outside the sector bound
    with pytest.raises(ValueError, match="cascade class"):
        encode(Gains(kp=10.0, Gamma=5.0, delta=0.9 / (V.m * 10.0)), V.m, 0.8, law_class="cascade")


@pytest.mark.parametrize("law_class", ["paper", "cascade"])
def test_a_filtered_pd_in_a_class_is_one_whose_image_is_in_the_class(law_class):
    """The image violation is zero exactly when the image lies in the class's NNI box; for the paper class on
    the sector coordinate that is k_p tau_f/k_d >= 1/gamma_max - 1 (by hand, filtered_pd_in_sector)."""
    law = law_of("pd_filtered", law_class)
    lim = gain_limits(V)
    rng = np.random.default_rng(11)
    seen = set()
    for _ in range(200):
        pd = PDFilteredGains(kp=math.exp(rng.uniform(0, 4)), kd=math.exp(rng.uniform(-1, 2.5)),
                             tau_f=math.exp(rng.uniform(-4.5, -1)))
        viol = law.image_violation(pd, V.m, 0.8, lim["kp_max"], lim["gamma_delta_max"])
        image = nni_from_filtered_pd(pd, V.m)
        in_box = image.kp <= lim["kp_max"] and image.Gamma * image.delta <= lim["gamma_delta_max"]
        gamma = ReducedLoop.from_vehicle(V, image).smallest_gamma
        in_class = in_box and (filtered_pd_in_sector(pd, 0.8) if law_class == "paper" else gamma <= 0.995)
        if law_class == "paper":
            in_class = in_class and ReducedLoop.from_vehicle(V, image).smallest_gamma >= 0.8 * math.exp(-4)
        assert (viol == 0) == in_class, (pd, viol)
        seen.add(in_class)
    assert seen == {True, False}
    assert law_of("pd_filtered", None).image_violation(PD, V.m, 0.8, 1.0, 1.0) == 0.0  # no class: no constraint


def test_a_pd_outside_its_class_is_ranked_above_every_simulated_candidate_without_a_run():
    from nniquad.tuning import objective as O

    options = TuneOptions(model="reduced", controller="pd_filtered", law_class="paper", roa_radius_m=0)
    inside = PDFilteredGains(kp=6.0, kd=3.5, tau_f=0.15)  # k_p tau_f/k_d = 0.26 >= 0.25
    assert filtered_pd_in_sector(inside, 0.8) and not filtered_pd_in_sector(PD, 0.8)
    q = np.array([encode(g, V.m, 0.8) for g in (PD, inside)])
    runs = O.simulations_run()
    out = O.evaluate_details(V, q, options, 10.0)
    assert O.simulations_run() - runs == 1  # only the one inside the class was simulated
    assert out[0]["cost"] >= O.CLASS_PENALTY_HORIZONS * 10.0 and out[0]["class_violation"] > 0
    assert out[1]["cost"] < 10.0
    free = O.evaluate_details(V, q, TuneOptions(model="reduced", controller="pd_filtered"), 10.0)
    assert free[0]["cost"] < 10.0  # without the class the same PD is an ordinary candidate


def test_warm_starts_map_across_the_equivalence():
    opts = TuneOptions(model="full", law_class="cascade")
    q = warm_start_coordinates(V, opts, [(PD, PD_INNER)], 1.0)[0]
    np.testing.assert_allclose(q[:3], encode(IMAGE, V.m, 0.8, law_class="cascade"), rtol=1e-12)
    assert math.exp(q[3]) == pytest.approx(PD_INNER.attitude_wn_rad_s)
    back = warm_start_coordinates(V, TuneOptions(model="reduced", controller="pd_filtered"), [(IMAGE, PD_INNER)],
                                  1.0)[0]
    np.testing.assert_allclose(back, encode(PD, V.m, 0.8), rtol=1e-10)
    unstable = Gains(kp=10.0, Gamma=5.0, delta=0.5 / (V.m * 10.0))
    assert warm_start_coordinates(V, opts, [(unstable, PD_INNER)], 1.0) == [None]


def test_the_full_model_ranks_the_discrete_controller_at_the_control_rate():
    """The tuner's nominal cost of a design is the settling time of the discrete controller at --rate, simulated
    here directly (and not the continuous one's)."""
    from nniquad.sim import SimOptions, simulate
    from nniquad.tuning import objective as O
    from nniquad.tuning.vehicle_limits import attitude_accel_headroom

    horizon = 12.0
    for rate in (100.0, 50.0):
        opts = TuneOptions(model="full", objective="nominal", require_margins=False, roa_radius_m=0.0,
                           law_class="cascade", rate_hz=rate)
        assert O.simulation_options(opts, horizon).sampling == "discrete"
        assert O.simulation_options(opts, horizon).rate_hz == rate
        scen = O.robust_scenarios(V, TuneOptions(model="full"))[1]
        assert scen.options(horizon, 30.0, PD_INNER, rate_hz=rate).sampling == "discrete"
        q = encode(IMAGE, V.m, 0.8, PD_INNER, attitude_accel_headroom(V, 30.0), law_class="cascade")
        cost = O.evaluate(V, q[None], opts, horizon)[0][0]
        base = SimOptions(model="full", horizon_s=horizon, output_dt_s=0.005, motor_lag=True, inner=PD_INNER)
        direct = simulate(V, IMAGE, base.with_(controller_sampling="discrete", noise_rate_hz=rate))[0].metrics()
        continuous = simulate(V, IMAGE, base)[0].metrics()
        assert cost == pytest.approx(direct.settling_s, abs=1e-9)
        assert abs(cost - continuous.settling_s) > 0.05


def test_a_seeded_tune_is_never_slower_than_its_seed():
    """Cascade class, reduced model: seeded with the tuned filtered PD, the result costs at most the PD's image."""
    from nniquad.tuning import objective as O
    from nniquad.tuning.tune import tune

    opts = TuneOptions(model="reduced", law_class="cascade", budget="quick", reruns=0)
    res = tune(V, opts, warm_starts=[(PD, PD_INNER)])
    seed_cost = O.evaluate(V, encode(IMAGE, V.m, 0.8, law_class="cascade")[None], opts, res.horizon_s)[0][0]
    assert res.settling_s <= seed_cost + 1e-9
    assert res.to_json()["law_class"] == "cascade" and res.gamma < 1.0


# ----------------------------------------------------------------------------- certificates


def test_the_paper_class_refuses_a_design_outside_the_sector_bound(run_cli, tmp_path):
    with pytest.raises(CertificateError, match="sector bound of the paper class.*--law-class cascade"):
        build_certificate(V, IMAGE, inner=PD_INNER, model="full", box=SMALL_BOX)
    out = tmp_path / "c.json"
    code, stdout, err = run_cli("certify", "--model", "full", "--kp", repr(IMAGE.kp), "--Gamma", repr(IMAGE.Gamma),
                                "--delta", repr(IMAGE.delta), "--out", str(out))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "sector bound" in err, err
    assert not out.exists()
    with pytest.raises(CertificateError, match="without one"):
        build_certificate(V, IMAGE, inner=PD_INNER, model="full", cascade=False, law_class="cascade")
    with pytest.raises(CertificateError, match="unknown law class"):
        build_certificate(V, IMAGE, inner=PD_INNER, model="full", law_class="pd")
    unstable = Gains(kp=10.0, Gamma=5.0, delta=0.9 / (V.m * 10.0))
    with pytest.raises(CertificateError, match="not stable"):
        build_certificate(V, unstable, model="full", law_class="cascade", box=SMALL_BOX)


def build_cascade_class_certificate() -> dict:
    """The mapped filtered PD's certificate in the cascade class over :data:`SMALL_BOX` (JSON; a 3-point grid)."""
    return build_certificate(V, IMAGE, inner=PD_INNER, model="full", box=SMALL_BOX, grid_points_per_axis=3,
                             law_class="cascade").to_json()


@pytest.fixture(scope="module")
def cascade_doc(shared_json) -> dict:
    return shared_json("law-class-cascade", build_cascade_class_certificate)


def _verify_edited(doc: dict, edit) -> tuple[bool, str | None]:
    c = copy.deepcopy(doc)
    edit(c)
    c["digest"]["value"] = canonical_digest(c)
    try:
        res = verify_certificate(c, simulate=False, fail_fast=True)
    except NniquadError as exc:
        return False, f"refused: {exc}"
    return res.ok, None if res.ok else res.first_failure.name


def test_a_cascade_certificate_states_and_verifies_its_class(cascade_doc):
    assert cascade_doc["law_class"] == {"name": "cascade", "theorem": LAW_CLASSES["cascade"].theorem}
    assert cascade_doc["sector"]["gamma"] > cascade_doc["sector"]["gamma_max"]
    res = verify_certificate(cascade_doc)
    assert res.ok, res.table()
    assert "cascade certificate" in res["law_class"].detail and "not claimed" in res["sector"].detail
    assert any("class cascade" in n for n in res.notes)


def test_verify_rejects_a_resigned_edit_of_the_law_class(cascade_doc):
    paper = LAW_CLASSES["paper"].theorem
    # relabelled paper (name and theorem): the sector bound it now claims does not hold
    assert _verify_edited(cascade_doc, lambda c: c["law_class"].update(name="paper", theorem=paper)) == (False,
                                                                                                          "sector")
    assert _verify_edited(cascade_doc, lambda c: c.pop("law_class")) == (False, "sector")  # no class: paper
    assert _verify_edited(cascade_doc, lambda c: c["law_class"].update(name="paper")) == (False, "law_class")
    assert _verify_edited(cascade_doc, lambda c: c["law_class"].update(theorem="Theorem 1")) == (False, "law_class")
    assert _verify_edited(cascade_doc, lambda c: c["law_class"].update(name="cascadex")) == (False, "law_class")
    assert _verify_edited(cascade_doc, lambda c: c["law_class"].update(extra=1)) == (False, "layout")

    # a cascade certificate without its cascade section is refused (schema 1 cannot carry the proof)
    def strip(c):
        c.pop("cascade")
        c["schema_version"] = 1

    assert _verify_edited(cascade_doc, strip) == (False, "law_class")


def test_certify_gains_from_a_filtered_pd_file_maps_it_to_its_image(run_cli, tmp_path):
    """``certify --gains-from`` reads a 'tune --json' file of a filtered PD and certifies its NNI image: under the
    paper class the image of this PD (gamma = k_d/(k_p tau_f + k_d) = 0.90 by hand, above 0.8) is refused in one
    line with exit 2 and no file; mixing --gains-from with given gains, or a file that is not a design, is a user
    error; the gamma the refusal states is the hand formula's."""
    import json

    design = tmp_path / "pd.json"
    design.write_text(json.dumps({"controller": "pd_filtered", "gains": {"kp": PD.kp, "kd": PD.kd, "tau_f": PD.tau_f},
                                  "inner_loop": {"attitude_wn_rad_s": PD_INNER.attitude_wn_rad_s,
                                                 "attitude_zeta": PD_INNER.attitude_zeta,
                                                 "attitude_accel_limit_rad_s2": PD_INNER.attitude_accel_limit_rad_s2}}))
    out = tmp_path / "c.json"
    code, _, err = run_cli("certify", "--model", "full", "--gains-from", str(design), "--out", str(out))
    gamma_by_hand = PD.kd / (PD.kp * PD.tau_f + PD.kd)
    assert gamma_by_hand > 0.8 + 1e-3
    assert code == 2 and len(err.strip().splitlines()) == 1 and "sector bound" in err, err
    assert f"{gamma_by_hand:.3g}" in err or f"{gamma_by_hand:.4g}" in err, err
    assert not out.exists()
    code, _, err = run_cli("certify", "--model", "full", "--gains-from", str(design), "--kp", "3", "--out", str(out))
    assert code == 2 and "not both" in err and not out.exists()
    code, _, err = run_cli("certify", "--model", "full", "--gains-from", str(design), "--warm-start", str(design),
                           "--out", str(out))
    assert code == 2 and "--warm-start" in err and not out.exists()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"gains": {"kp": 1.0}}))
    code, _, err = run_cli("certify", "--model", "full", "--gains-from", str(bad), "--out", str(out))
    assert code == 2 and err.startswith("nniquad certify: error: --gains-from") and not out.exists()


def test_gains_from_keeps_the_record_of_the_tune_that_found_them(monkeypatch):
    """``certify --gains-from FILE``: the certificate's ``tuning`` record is the file's (a certificate's ``tuning``
    section, a ``tune --json`` document), when that tune ran on the certified model; otherwise only the source."""
    from pathlib import Path

    import nniquad.jobs.certify as job
    from nniquad.certificates import read_certificate
    from nniquad.cli.commands.tune_command import designs_from_files
    from nniquad.tuning.tune import TuneOptions

    data = Path(__file__).resolve().parents[1] / "notebooks" / "data"
    committed = data / "full_model_certificate.json"
    records: list = []
    (gains, inner), (pd, _) = designs_from_files([committed, data / "designs" / "pd_filtered.json"], "--gains-from",
                                                 records)
    stated = json.loads(committed.read_text())["tuning"]
    assert records[0] == stated and records[1] == json.loads((data / "designs" / "pd_filtered.json").read_text())
    captured = []
    monkeypatch.setattr(job, "build_certificate", lambda *a, **k: captured.append(k["tuning"]) or
                        read_certificate(committed))
    job.certify(V, gains, inner=inner, options=TuneOptions(model="full"), tuning_record=records[0])
    assert captured[-1]["settling_s"] == stated["settling_s"] and captured[-1]["model"] == "full"
    assert captured[-1]["source"].startswith("given gains, with the record")
    job.certify(V, gains, inner=inner, options=TuneOptions(model="reduced"), tuning_record=records[0])
    assert captured[-1] == {"source": "given gains"}  # a record of another model is not this certificate's
    job.certify(V, gains, inner=inner, options=TuneOptions(model="full"))
    assert captured[-1] == {"source": "given gains"}


def test_the_sector_face_the_tuner_decodes_is_inside_the_bound_as_verify_recomputes_it():
    """The fastest paper-class designs sit on ``u = 0`` (γ = γ_max); recomputed from the stated gains γ lands an
    ulp or two either side, and must read as inside the bound (the ``sni2`` tune once printed "0.8 > gamma_max
    0.8").  The allowance is rounding-sized: a design 1e-9 outside is still outside, and is refused."""
    from nniquad.analysis.reduced_loop import reduced_loop
    from nniquad.laws.sni2 import SNI2Gains
    from nniquad.laws.classes import SECTOR_RTOL, within_sector_bound

    g_max = 0.8
    assert within_sector_bound(g_max * (1 + 2.0**-52), g_max) and within_sector_bound(g_max, g_max)
    assert not within_sector_bound(g_max * (1 + 1e-9), g_max) and 1e-9 >= 1e3 * SECTOR_RTOL
    rng = np.random.default_rng(24)
    above = 0
    for controller, rest in (("sni2", lambda: [math.log(rng.uniform(0.5, 300.0)), math.log(rng.uniform(0.1, 4.0))]),
                             ("nni", lambda: [math.log(rng.uniform(0.05, 300.0))])):
        law = law_of(controller, "paper")
        for _ in range(200):
            q = [math.log(rng.uniform(0.5, 2000.0)), 0.0, *rest()]
            gains = law.decode(q, V.m, g_max)
            gamma = reduced_loop(V, gains).smallest_gamma
            assert within_sector_bound(gamma, g_max), (controller, q, gamma)
            assert abs(gamma - g_max) <= 8 * 2.0**-52 * g_max  # on the face to rounding: the test's premise
            above += gamma > g_max
    # an sni2 design a relative 1e-9 above the face is refused by certify, in one message naming the bound
    face = law_of("sni2", "paper").decode([math.log(40.0), 0.0, math.log(10.0), math.log(0.6)], V.m, g_max)
    outside = SNI2Gains(kp=face.kp, k=face.k * (1 + 1e-9), omega=face.omega, zeta=face.zeta)
    with pytest.raises(CertificateError, match="sector bound of the paper class"):
        build_certificate(V, outside, model="full", box=SMALL_BOX)
    print(f"{above} of 400 face designs recompute a gamma above gamma_max by rounding")
