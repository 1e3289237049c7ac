# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 4 · Velocity-free NNI control against velocity feedback
#
# The point of the paper's controller is that it needs no horizontal velocity.
# What does that cost against the obvious alternative, a PD law?  Three
# horizontal controllers are compared on the `full` vehicle (inner loops,
# rotor saturation, motor lag), all choosing from the same inner loops:
#
# * **NNI, paper class** -- the paper's structure a = −k_p ξ + z/m with the
#   integral resonant controller, gains under the sector bound (certified by
#   the paper's theorem and the sampled-data cascade certificate);
# * **NNI, cascade class** -- the same law without the sector bound, certified
#   by the sampled-data cascade certificate alone.  This class *contains* the
#   filtered-derivative PD below: a PD with the derivative filtered by
#   s/(τ_f s + 1) is the NNI law with k_p' = k_p + k_d/τ_f, Γ = m k_d/τ_f²,
#   δ = τ_f/(m k_d) (notebook 3, section 6);
# * **SNI2, cascade class** -- a second-order strictly negative-imaginary
#   controller k/(s² + 2ζωs + ω²) in place of the integral resonant one (law
#   `"sni2"`), certified the same way; its tuned certificate and that design run
#   faster and slower (`time_scaled`) are its candidates;
# * **SNI2, paper class** -- the same controller under the paper's sector bound
#   k/(m k_p ω²) ≤ γ_max, certified by the paper's theorem like the NNI law
#   (with its 2.5 m certified reach); its time-scaled family likewise;
# * **PD, true velocity** -- a = −k_p ξ − k_d ξ' with a perfect velocity
#   sensor (gains `PDGains`, law `"pd_velocity"`), the best a PD law can do;
# * **PD, filtered derivative** -- the same law with the velocity estimated
#   from the measured position by s/(τ_f s + 1) (gains `PDFilteredGains`, law `"pd_filtered"`),
#   what one would do without a velocity sensor.
#
# Each is compared twice: with a perfect position measurement and with
# position noise (σ = 1 cm, sampled at 100 Hz).  Noise changes what the best
# gains are, so every design is tuned again for the noisy case before the
# comparison.  The figures of merit are the settling time (2 % band) and the
# tilt jitter, i.e. how much the vehicle keeps rocking once it has arrived.

# %%
import math
import time
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np

from nniquad import (
    bound as time_optimal_bound,
    certified_reach,
    decode,
    DEFAULT_TAU_F_S,
    notebook_size,
    notebook_vehicle,
    PDFilteredGains,
    PDGains,
    notebook_certificate,
    ReducedLoop,
    rms_after,
    show_figure as show,
    show_table as md_table,
    SimOptions,
    simulate,
    sized,
    TILT_SLACK_DEG,
    TuneOptions,
)

from nniquad.laws.sni2 import SNI2Gains
from nniquad.analysis.reduced_loop import reduced_loop
from nniquad.laws.classes import within_sector_bound

T_START = time.perf_counter()
V = notebook_vehicle()  # the file $NNIQUAD_VEHICLE names (TOML or JSON); unset: the paper's vehicle
GAMMA_MAX = TuneOptions().gamma_max
HORIZON_S = 8.0
JITTER_FROM_S = HORIZON_S / 2  # tilt jitter is measured over [JITTER_FROM_S, HORIZON_S] ...
MAX_SETTLING_S = JITTER_FROM_S  # ... so only designs settled by then are compared
NOISE = dict(noise_sigma_m=0.01, noise_rate_hz=100.0)
CTRL_LABEL = {"nni": "NNI, paper class", "nni_cascade": "NNI, cascade class",
              "sni2": "SNI2, cascade class", "sni2_paper": "SNI2, paper class", "pd_velocity": "PD, true velocity",
              "pd_filtered": "PD, filtered derivative"}
CTRL_COLOR = {"nni": "tab:blue", "nni_cascade": "tab:purple", "sni2": "tab:red", "sni2_paper": "tab:brown",
              "pd_velocity": "tab:green",
              "pd_filtered": "tab:orange"}






# %% [markdown]
# ## The certified NNI design and the common inner loops
#
# The NNI gains and the attitude loop come from the certificate
# `notebooks/data/full_model_certificate.json`, written by `nniquad certify
# --model full` (the tuner's defaults: robust objective, normal budget, seed 0; too
# slow to rerun here; notebook 3 shows why the quick budget's result is not
# usable).  Its sector bound and certified reach are
# recomputed.  The PD controllers get the same inner loops (and the same
# alternatives to them, below).

# %%
# tuned and written by `nniquad certify --model full --out notebooks/data/full_model_certificate.json`,
# re-certified with the current code (same gains and tuning record) by `nniquad certify --model full
# --gains-from notebooks/data/full_model_certificate.json --out notebooks/data/full_model_certificate.json`;
# notebook_certificate reads notebooks/data whatever the working folder, checks the schema and SHA-256 digest,
# and refuses a certificate of another vehicle than V
CERT = notebook_certificate("full_model_certificate.json", vehicle=V)
# written by `nniquad certify --model full --law-class cascade ...` (notebooks/data/make_data.py)
CASCADE_CERT = notebook_certificate("cascade_model_certificate.json", vehicle=V)
NNI_REF = CERT.gains
NNI_CASCADE_REF = CASCADE_CERT.gains
# written by `nniquad certify --model full --controller sni2 --law-class cascade ...` (make_data.py, sni2_cascade)
SNI2_REF = notebook_certificate("sni2_cascade_certificate.json", vehicle=V).gains
# written by `nniquad certify --model full --controller sni2 ...` (make_data.py, sni2_paper): the paper class
SNI2_PAPER_REF = notebook_certificate("designs", "sni2_paper_certificate.json", vehicle=V).gains
INNER = CERT.inner_loop
BASE = SimOptions(model="full", horizon_s=HORIZON_S, motor_lag=True, inner=INNER)
TILT_CAP = BASE.tilt_limit_deg + TILT_SLACK_DEG
print(f"NNI: kp = {NNI_REF.kp:.4g}, Γ = {NNI_REF.Gamma:.4g}, δ = {NNI_REF.delta:.4g}; smallest γ = "
      f"{ReducedLoop.from_vehicle(V, NNI_REF).smallest_gamma:.4f} (γ_max {GAMMA_MAX:g}); certified reach "
      f"{certified_reach(ReducedLoop.from_vehicle(V, NNI_REF), BASE.tilt_limit_deg):.2f} m")
print(f"inner loops: ω_a = {INNER.attitude_wn_rad_s:.4g} rad/s, ζ_a = {INNER.attitude_zeta:.3f}; motor lag τ = "
      f"{1000 * V.tau_motor:g} ms; admissible actual tilt ≤ {TILT_CAP:g}°")

# %% [markdown]
# ## How the designs are scored
#
# For every controller a grid of gain sets is simulated in one batch
# (`nniquad.sim.simulate`; all runs of a comparison share one noise
# realisation).  A run is *admissible* when it settles within the first half
# of the horizon, its actual tilt stays within the limit plus the tuner's
# slack, and it holds altitude within 0.5 m (a chattering attitude loop can
# settle horizontally while the vehicle sinks, see notebook 3).  The tilt
# jitter is the RMS tilt over the second half of the run
# (`nniquad.sim.metrics.rms_after`), when every admissible run has arrived, so it
# measures the response to noise and not the tail of the manoeuvre;
# `Metrics.tilt_jitter_rms_deg` (RMS tilt from the settling time on) is shown
# as well for the chosen designs.
#
# Grids: PD over k_p and the damping ratio of its nominal loop,
# k_d = 2ζ√k_p (the filtered PD also over τ_f); NNI in the tuner's coordinates
# (`nniquad.tuning.tune.decode`: k_p, m k_p δ on or above the sector bound, and the
# controller pole Γδ, here in units of √k_p as in notebook 2), so every paper-class
# NNI candidate satisfies the sector bound; the cascade-class grid takes m k_p δ
# below it (1.05 and 1.15), where the filtered PDs' images lie.  The
# cascade class's proof is the sampled-data cascade certificate, computed
# per design: here only the two tuned certificates are certified designs
# (the cascade grid points and the time-scaled SNI2 designs are members of
# the class's coordinates, not certified one by one; notebook 3 section 6
# gives the certified designs' robust figures).  Every grid
# is run for three attitude-loop bandwidths shared by all controllers, the
# tuned one and two slower ones:
# noise enters every law through the position term, and a fast attitude loop
# passes it on to the tilt.

# %%
# sized(full, smoke): `make test` runs this notebook on the smoke grids (NNIQUAD_NOTEBOOK_SIZE=smoke)
PD_KP = np.geomspace(1.0, 60.0, sized(12, 5))
PD_ZETA = sized((0.4, 0.55, 0.7, 0.85, 1.0, 1.3), (0.55, 0.85, 1.3))  # k_d = 2 ζ √k_p
PF_KP = np.geomspace(1.0, 60.0, sized(10, 5))
PF_ZETA = sized((0.4, 0.6, 0.8, 1.0, 1.3), (0.6, 1.0))
PF_TAU = sized((0.01, 0.03, 0.1), (0.01, 0.03))  # τ_f [s]
NNI_KP = np.geomspace(1.0, 60.0, sized(12, 5))
NNI_MARGIN = (1.0, 1.25)  # m kp δ in units of the sector bound 1/γ_max
NNI_R = sized((0.75, 1.0, 1.35, 1.8), (1.0, 1.35))  # controller pole Γδ in units of √k_p
NNI_CASCADE_MKD = (1.05, 1.15)  # m kp δ below the sector bound's 1/γ_max = 1.25 (cascade class only)
SNI2_LAMBDA = sized((0.6, 0.8, 0.9, 1.1, 1.25, 1.6), (0.8, 1.25))  # the certified SNI2 design run λ times faster

CANDIDATES = {
    "pd_velocity": [PDGains(kp, 2 * z * math.sqrt(kp)) for kp in PD_KP for z in PD_ZETA],
    "pd_filtered": [PDFilteredGains(kp, 2 * z * math.sqrt(kp), tf) for kp in PF_KP for z in PF_ZETA for tf in PF_TAU],
    "nni": [decode([math.log(kp), math.log(mg), math.log(r * math.sqrt(kp))], V.m, GAMMA_MAX)[0]
            for kp in NNI_KP for mg in NNI_MARGIN for r in NNI_R] + [NNI_REF],
    # cascade class: v = ln(m kp delta - 1) (nniquad.laws.search_ranges); the paper-class grid is a subset of the class
    "nni_cascade": [decode([math.log(kp), math.log(mkd - 1.0), math.log(r * math.sqrt(kp))], V.m, GAMMA_MAX,
                           law_class="cascade")[0]
                    for kp in NNI_KP for mkd in NNI_CASCADE_MKD for r in NNI_R] + [NNI_CASCADE_REF],
    "sni2": [SNI2_REF.time_scaled(lam) for lam in SNI2_LAMBDA] + [SNI2_REF],
    # time scaling keeps the DC loop gain k/(m kp omega^2), so the family stays in the paper class
    "sni2_paper": [SNI2_PAPER_REF.time_scaled(lam) for lam in SNI2_LAMBDA] + [SNI2_PAPER_REF],
}
NI_SETS = tuple(c for c in CANDIDATES if not c.startswith("pd_"))  # the certified NI laws' candidate sets
CONTROLLER_OF = {"nni_cascade": "nni", "sni2_paper": "sni2"}  # the candidate set's law where its name is not the law's
assert all(within_sector_bound(reduced_loop(V, g).smallest_gamma, GAMMA_MAX)
           for c in ("nni", "sni2_paper") for g in CANDIDATES[c])
assert all(GAMMA_MAX < ReducedLoop.from_vehicle(V, g).smallest_gamma < 1 for g in CANDIDATES["nni_cascade"][:-1])


def score(controller, options, gains_list):
    """Simulate a batch; return rows (gains, settling, jitter, peak tilt, altitude dev, Metrics jitter, admissible)."""
    res = simulate(V, gains_list, options)  # the law is the type of the gain blocks
    assert res.controller == controller
    rows = []
    for g, m, tr in zip(gains_list, res.metrics(), res):
        jit = rms_after(tr.t, tr.tilt_deg, JITTER_FROM_S) if not m.diverged else None
        ok = (m.settling_s is not None and m.settling_s <= MAX_SETTLING_S and m.peak_tilt_deg is not None
              and m.peak_tilt_deg <= TILT_CAP and m.altitude_dev_m is not None and m.altitude_dev_m < 0.5
              and jit is not None)
        rows.append(dict(gains=g, settling=m.settling_s, jitter=jit, tilt=m.peak_tilt_deg, alt=m.altitude_dev_m,
                         metrics_jitter=m.tilt_jitter_rms_deg, ok=ok, options=options))
    return rows


def fmt_gains(g):
    if isinstance(g, PDGains):
        return f"k_p = {g.kp:.3g}, k_d = {g.kd:.3g}"
    if isinstance(g, PDFilteredGains):
        return f"k_p = {g.kp:.3g}, k_d = {g.kd:.3g}" + (f", τ_f = {g.tau_f:.3g}" if g.tau_f != DEFAULT_TAU_F_S else "")
    if isinstance(g, SNI2Gains):
        return f"k_p = {g.kp:.3g}, k = {g.k:.3g}, ω = {g.omega:.3g}, ζ = {g.zeta:.3g}"
    return f"k_p = {g.kp:.3g}, Γ = {g.Gamma:.3g}, δ = {g.delta:.3g}"


# %% [markdown]
# ## Without noise
#
# With a perfect position measurement every controller is tuned on the grid
# for the shortest settling time.  For NNI the tuned reference set is in the
# candidate list as well.

# %%
WA_GRID = tuple(f * INNER.attitude_wn_rad_s for f in (0.5, 0.75, 1.0))  # the tuned one and two slower ones


def score_all(base):
    out = {c: [] for c in CANDIDATES}
    for wa in WA_GRID:
        opt_wa = base.with_(inner=replace(INNER, attitude_wn_rad_s=wa))
        for c in CANDIDATES:
            out[c] += score(CONTROLLER_OF.get(c, c), opt_wa, CANDIDATES[c])
    return out


t0 = time.perf_counter()
clean = score_all(BASE)
clean_time = time.perf_counter() - t0
n_clean = sum(len(v) for v in clean.values())
best_clean = {c: min((r for r in rows if r["ok"]), key=lambda r: r["settling"]) for c, rows in clean.items()
              if any(r["ok"] for r in rows)}


def row_of(results, law, gains):
    """The scored row of ``gains`` (one of the law's candidates) on the tuned inner loops."""
    return next(r for r in results[law] if r["gains"] is gains and r["options"].inner == INNER)


ref_clean = row_of(clean, "nni", NNI_REF)
md_table(["controller", "best gains on the grid", "ω_a [rad/s]", "settling [s]", "peak tilt [deg]", "admissible / tried"],
         [[CTRL_LABEL[c], fmt_gains(r["gains"]), f"{r['options'].inner.attitude_wn_rad_s:.0f}", f"{r['settling']:.3f}",
           f"{r['tilt']:.1f}",
           f"{sum(x['ok'] for x in clean[c])} / {len(clean[c])}"] for c, r in best_clean.items()])
print(f"{n_clean} full-model runs of {HORIZON_S:g} s in {clean_time:.1f} s; "
      f"the tuned NNI reference set settles in {ref_clean['settling']:.3f} s")
bound_s = time_optimal_bound(V).enter_band_s
print(f"time-optimal lower bound under the tilt limit: {bound_s:.3f} s")


def best_by_wa(results):
    """Shortest admissible settling per controller and attitude bandwidth (nan: none admissible)."""
    out = {}
    for c, rows in results.items():
        for wa in WA_GRID:
            s_ok = [r["settling"] for r in rows if r["ok"] and r["options"].inner.attitude_wn_rad_s == wa]
            out[c, wa] = min(s_ok) if s_ok else float("nan")
    return out


clean_wa = best_by_wa(clean)
md_table(["controller"] + [f"best settling at ω_a = {wa:.0f} rad/s [s]" for wa in WA_GRID],
         [[CTRL_LABEL[c]] + [f"{clean_wa[c, wa]:.3f}" for wa in WA_GRID] for c in CANDIDATES])

# %% [markdown]
# ## With position noise
#
# The same grids (same three attitude bandwidths) are run again with noise.
# Each point below is one admissible (controller, gains, ω_a); the lines are
# each controller's Pareto front: the shortest settling time reachable for a
# given jitter.

# %%
t0 = time.perf_counter()
noisy = score_all(BASE.with_(**NOISE))
noisy_time = time.perf_counter() - t0
n_noisy = sum(len(v) for v in noisy.values())
print(f"{n_noisy} noisy full-model runs of {HORIZON_S:g} s in {noisy_time:.1f} s")
ref_noisy = row_of(noisy, "nni", NNI_REF)
print(f"the noise-free NNI reference under noise, unchanged: settling "
      f"{'not within ' + format(MAX_SETTLING_S, 'g') + ' s' if ref_noisy['settling'] is None else format(ref_noisy['settling'], '.2f') + ' s'}, "
      f"altitude deviation {ref_noisy['alt']:.2f} m, admissible: {ref_noisy['ok']}")


def pareto(rows):
    """Admissible rows on the front: no other row has both less jitter and shorter settling."""
    good = sorted((r for r in rows if r["ok"]), key=lambda r: (r["jitter"], r["settling"]))
    front, best = [], np.inf
    for r in good:
        if r["settling"] < best:
            front.append(r)
            best = r["settling"]
    return front


fronts = {c: pareto(rows) for c, rows in noisy.items()}

fig, ax = plt.subplots(figsize=(9, 5.5))
for c, rows in noisy.items():
    ok = [r for r in rows if r["ok"]]
    ax.scatter([r["jitter"] for r in ok], [r["settling"] for r in ok], s=10, alpha=0.35, color=CTRL_COLOR[c])
    fr = fronts[c]
    ax.step([r["jitter"] for r in fr], [r["settling"] for r in fr], where="post", color=CTRL_COLOR[c], lw=2,
            label=f"{CTRL_LABEL[c]} ({len(ok)} admissible)")
for c, r in best_clean.items():
    ax.axhline(r["settling"], color=CTRL_COLOR[c], ls=":", lw=1)
ax.set_xscale("log")
ax.set_xlabel(f"tilt jitter: RMS tilt over t ≥ {JITTER_FROM_S:g} s [deg]")
ax.set_ylabel("settling time with noise [s]")
ax.set_title(f"position noise σ = {100 * NOISE['noise_sigma_m']:g} cm at {NOISE['noise_rate_hz']:g} Hz; "
             "dotted: each controller's best without noise")
ax.legend(fontsize=8)
fig.tight_layout()
show(fig)

# %% [markdown]
# ## Which wins where
#
# For a few jitter budgets, each controller's fastest admissible design under
# noise.  The chosen designs are then simulated again with a *different* noise
# realisation (seed 1), to check that the choice did not just fit one noise
# sequence.

# %%
JITTER_CAPS = (0.25, 0.5, 1.0, 2.0)  # deg RMS
win_rows, winners, picks = [], {}, {}
for cap in JITTER_CAPS:
    cells, best = [], {}
    for c in CANDIDATES:
        cand = [r for r in noisy[c] if r["ok"] and r["jitter"] <= cap]
        if cand:
            r = min(cand, key=lambda r: r["settling"])
            best[c] = r
            cells.append(f"{r['settling']:.2f} s (ω_a = {r['options'].inner.attitude_wn_rad_s:.0f})")
        else:
            cells.append("none")
    w = min(best, key=lambda c: best[c]["settling"]) if best else None
    winners[cap] = w
    picks[cap] = best
    win_rows.append([f"≤ {cap:g}°"] + cells + [CTRL_LABEL[w] if w else "—"])
md_table(["jitter budget"] + [CTRL_LABEL[c] for c in CANDIDATES] + ["fastest"], win_rows)

# re-check the picks of one budget on a second noise realisation
CHECK_CAP = 1.0
check_rows = []
for c, r in picks[CHECK_CAP].items():
    tr = simulate(V, r["gains"], r["options"].with_(seed=1))[0]
    m = tr.metrics()
    check_rows.append([CTRL_LABEL[c], fmt_gains(r["gains"]), f"{r['options'].inner.attitude_wn_rad_s:.0f}",
                       f"{r['settling']:.2f}", f"{r['jitter']:.3f}", f"{r['metrics_jitter']:.3f}",
                       "—" if m.settling_s is None else f"{m.settling_s:.2f}",
                       f"{rms_after(tr.t, tr.tilt_deg, JITTER_FROM_S):.3f}"])
md_table(["controller", f"gains (jitter ≤ {CHECK_CAP:g}°)", "ω_a [rad/s]", "settling, seed 0 [s]",
          "jitter, seed 0 [deg]", "Metrics.tilt_jitter_rms_deg [deg]", "settling, seed 1 [s]", "jitter, seed 1 [deg]"],
         check_rows)

# %% [markdown]
# **Reading the comparison.**  Without noise the tilt limit sets a floor, the
# time-optimal bound.  How close each law comes to it with the attitude loop
# the tuner allows (capped against the motor lag, notebook 3), and how much
# each loses with a slower attitude loop, is computed in the conclusion below:
# with the capped attitude loop the velocity-free NNI loop, whose poles are
# lightly damped (notebook 1), stays well above the PD laws.  Noise separates
# them further.  The PD law with a true velocity does not
# differentiate the noise, so it can keep high gains for a small jitter; the
# two velocity-free laws both have to turn the noisy position into damping,
# the filtered PD by differentiating it, NNI through its resonant controller
# state, and both must give up speed to keep the jitter down.  The table
# above states, budget by budget, which of them is faster.

# %%
# conclusion -- every number below was computed in this notebook
elapsed = time.perf_counter() - T_START
nni_c, nnic_c, pdv_c, pdf_c = (best_clean[c]["settling"] for c in ("nni", "nni_cascade", "pd_velocity", "pd_filtered"))
ref_cascade = row_of(clean, "nni_cascade", NNI_CASCADE_REF)
ref_sni2 = row_of(clean, "sni2", SNI2_REF)
sni2_c = best_clean["sni2"]["settling"] if "sni2" in best_clean else math.nan
ref_sni2p = row_of(clean, "sni2_paper", SNI2_PAPER_REF)
sni2p_c = best_clean["sni2_paper"]["settling"] if "sni2_paper" in best_clean else math.nan
certified_best = min(NI_SETS, key=lambda c: best_clean[c]["settling"] if c in best_clean
                     else math.inf)
print("Conclusion")
print(f"- Without noise (same inner-loop candidates for all): NNI paper class {nni_c:.2f} s (the tuned "
      f"certified set: {ref_clean['settling']:.2f} s), NNI cascade class {nnic_c:.2f} s (its certified set on these "
      f"inner loops: {ref_cascade['settling']:.2f} s), PD with true velocity {pdv_c:.2f} s, PD with a filtered "
      f"derivative {pdf_c:.2f} s. The velocity sensor buys {100 * (1 - pdv_c / min(nni_c, nnic_c)):.0f} % over the "
      f"faster NNI class; the cascade-class NNI is {'faster' if nnic_c < pdf_c else 'slower'} than the filtered PD "
      f"by {abs(pdf_c - nnic_c):.2f} s on these grids (the class contains every filtered PD), the paper class "
      f"{'faster' if nni_c < pdf_c else 'slower'} by {abs(pdf_c - nni_c):.2f} s. SNI2 cascade class: "
      f"{sni2_c:.2f} s over its time-scaled certified design (the certified design itself "
      f"{'not admissible here' if ref_sni2['settling'] is None else format(ref_sni2['settling'], '.2f') + ' s'}). "
      f"SNI2 paper class (the paper's theorem, like the NNI paper class): {sni2p_c:.2f} s over its time-scaled "
      f"certified design (the certified design itself "
      f"{'not admissible here' if ref_sni2p['settling'] is None else format(ref_sni2p['settling'], '.2f') + ' s'}"
      f"; {'faster' if sni2p_c < nni_c else 'not faster'} than the NNI paper class). "
      f"Fastest law of the NI structure without noise: {CTRL_LABEL[certified_best]}; "
      f"{'it beats' if best_clean[certified_best]['settling'] < pdf_c else 'it does not beat'} the filtered PD and "
      f"{'beats' if best_clean[certified_best]['settling'] < pdv_c else 'does not beat'} the PD with true velocity.")
pick_wa = sorted({b[c]["options"].inner.attitude_wn_rad_s for b in picks.values() for c in b})
slow_wa, fast_wa = min(WA_GRID), max(WA_GRID)
# "not <=" so that no admissible design at the slowest ω_a (nan) counts as needing the fast loop
nni_needs_fast = not clean_wa["nni", slow_wa] <= 1.25 * clean_wa["nni", fast_wa]
pd_needs_fast = not clean_wa["pd_velocity", slow_wa] <= 1.25 * clean_wa["pd_velocity", fast_wa]


def secs(x):
    return "none admissible" if not math.isfinite(x) else f"{x:.2f} s"


lean = {(True, False): "NNI leans on a fast attitude loop, PD does not",
        (True, True): "both NNI and PD need a fast attitude loop",
        (False, False): "neither NNI nor PD needs a fast attitude loop",
        (False, True): "PD needs a fast attitude loop, NNI does not"}[nni_needs_fast, pd_needs_fast]
print(f"- {lean} (more than 25 % slower at the slowest ω_a): without noise NNI's best is "
      + ", ".join(secs(clean_wa['nni', wa]) for wa in WA_GRID) + " at ω_a = "
      + ", ".join(f"{wa:.0f}" for wa in WA_GRID) + " rad/s; PD with true velocity "
      + ", ".join(secs(clean_wa['pd_velocity', wa]) for wa in WA_GRID)
      + f" (time-optimal bound {bound_s:.2f} s).")
print(f"- With {100 * NOISE['noise_sigma_m']:g} cm position noise the noise-free NNI set is "
      f"{'no longer admissible' if not ref_noisy['ok'] else 'still admissible'} "
      f"(altitude deviation {ref_noisy['alt']:.2f} m with its attitude loop); every design is re-tuned for the noise; "
      f"the picks below use ω_a = {', '.join(f'{w:.0f}' for w in pick_wa)} rad/s.")
for cap in JITTER_CAPS:
    b = picks[cap]
    parts = ", ".join(f"{CTRL_LABEL[c]} {b[c]['settling']:.2f} s" for c in b)
    missing = [CTRL_LABEL[c] for c in CANDIDATES if c not in b]
    print(f"- Jitter ≤ {cap:g}° RMS: {parts}" + (f" ({', '.join(missing)}: none admissible)" if missing else "")
          + (f" → {CTRL_LABEL[winners[cap]]} wins." if winners[cap] else "."))
vf = {cap: [c for c in (*NI_SETS, "pd_filtered") if c in picks[cap]] for cap in JITTER_CAPS}
vf_win = {cap: min(vf[cap], key=lambda c: picks[cap][c]["settling"]) for cap in JITTER_CAPS if vf[cap]}
print("- Among the velocity-free laws: " + "; ".join(f"≤ {cap:g}°: {CTRL_LABEL[c]}" for cap, c in vf_win.items()) + ".")
print(f"(notebook ran in {elapsed:.0f} s, {notebook_size()} grids)")
