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
# # 1 · Reproducing the paper
#
# Ghallab & Petersen regulate the horizontal position of a quadrotor with a
# proportional inner loop and an integral resonant (NNI) controller in positive
# feedback, with the gains of their Table "Simulation Parameters"
# (`nniquad.PAPER_GAINS`).  Their Section "Simulation Results" announces
# a figure (`fig:position_tracking`) whose `\includegraphics` is empty, and
# describes it as "smooth transient response with no oscillations or
# overshoot".
#
# This notebook runs the paper's gains on the three models of
# `nniquad.sim`:
#
# * `linear` -- the reduced horizontal loop the theorem covers (no limits);
# * `reduced` -- the same with the tilt limit (attitude instantaneous);
# * `full` -- the 12-state vehicle with the attitude, altitude and yaw loops of
#   `nniquad.control.inner_loops` and rotor saturation.
#
# It draws the missing figure, lists the closed-loop poles and their damping,
# explains why the full vehicle does not settle, and prints the audit's
# verdicts on the simulation section (`proofs.simulation`).  Every number below
# is computed here.

# %%
import math
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image, display
from scipy.optimize import brentq

from nniquad import (
    audit,
    axis_acceleration_limit,
    DEFAULT_INNER_LOOP_GAINS,
    paper_figure,
    PAPER_FIGURE_HORIZON_S,
    paper_figure_runs,
    PAPER_GAINS,
    notebook_vehicle,
    PAPER_VEHICLE,
    ReducedLoop,
    region_of_attraction,
    show_figure as show,
    show_table as md_table,
    SimOptions,
    simulate,
    TILT_LIMIT_DEG,
    XI0_M,
)

T_START = time.perf_counter()
# reproducing the paper means its vehicle: this notebook does not take $NNIQUAD_VEHICLE (notebooks 02-04 do)
V = PAPER_VEHICLE
if notebook_vehicle() != V:
    print(f"note: $NNIQUAD_VEHICLE names {notebook_vehicle().name!r}; this notebook reproduces the paper, "
          "on the paper's vehicle")
G = PAPER_GAINS
OUT = Path(tempfile.mkdtemp(prefix="nniquad-nb01-"))




print(f"vehicle: m = {V.m} kg, g = {V.g} m/s², thrust-to-weight {V.thrust_to_weight():.2f}")
print(f"paper gains: kp = {G.kp:g} 1/s², Γ = {G.Gamma:g}, δ = {G.delta:g}")

# %% [markdown]
# ## The sector bound the paper checks
#
# The paper picks γ = 0.8 and checks δ ≥ δ_min = 1/(γ m k_p).  For this loop
# the sector condition reduces to a DC-loop-gain condition: the smallest γ
# that works for a gain set is G(0)C(0) = 1/(m k_p δ) (`nniquad.analysis.reduced_loop`).

# %%
GAMMA_PAPER = 0.8
LOOP = ReducedLoop.from_vehicle(V, G)
delta_min = LOOP.sector_limit(GAMMA_PAPER)[1]
gamma_needed = LOOP.smallest_gamma
print(f"δ_min(γ = {GAMMA_PAPER}) = {delta_min:.4f}; the paper's δ = {G.delta:g} satisfies it: {G.delta >= delta_min}")
print(f"smallest γ these gains satisfy: {gamma_needed:.4f} (m kp δ = {V.m * G.kp * G.delta:.3f})")

# %% [markdown]
# ## Closed-loop poles and damping
#
# Per axis the closed loop is third order, with characteristic polynomial
# s³ + Γδ s² + k_p s + Γ(k_p δ − 1/m).  The sector bound guarantees
# stability, not damping: the large Γ puts one pole far to the left and leaves
# a lightly damped pair near the plant's own resonance √k_p.

# %%
pdmp = LOOP.poles_and_damping()
seen = set()
rows = []
for p, wn, z in zip(pdmp.poles, pdmp.wn, pdmp.zeta):
    key = (round(p.real, 9), round(abs(p.imag), 9))
    if key in seen:  # both axes are identical: show each pole once
        continue
    seen.add(key)
    im = f" ± {abs(p.imag):.4f}j" if abs(p.imag) > 0 else ""
    rows.append([f"{p.real:.4f}{im}", f"{wn:.4f}", f"{z:.4f}"])
md_table(["pole [1/s]", "ω_n [rad/s]", "ζ"], rows)

dominant = pdmp.poles[np.argmax(pdmp.poles.real)]
sigma_dom = -dominant.real
omega_dom = abs(dominant.imag)
fast_pole = float(np.min(pdmp.poles.real))
period_dom = 2 * math.pi / omega_dom
# envelope estimate of the 2 % settling time: the envelope e^{-σ t} reaches 2 %
t_envelope = math.log(1 / 0.02) / sigma_dom
print(f"dominant pair: σ = {sigma_dom:.4f} 1/s, ω = {omega_dom:.3f} rad/s (period {period_dom:.2f} s), "
      f"ζ = {pdmp.min_damping:.4f}; fast real pole {fast_pole:.1f} 1/s")
print(f"envelope estimate of the 2 % settling time ln(50)/σ = {t_envelope:.0f} s")

# %% [markdown]
# ## The missing figure
#
# `nniquad.sim.paper_figure_runs` runs the three models from
# the paper's initial position at rest over `PAPER_FIGURE_HORIZON_S` (long
# enough to see the linear loop settle); `nniquad.sim.plots.paper_figure` draws
# x(t), y(t), the distance on a log scale with the 2 % band, and a zoom on the
# first seconds with the tilt.

# %%
runs = paper_figure_runs(V, G, horizon_s=PAPER_FIGURE_HORIZON_S)
fig_path = paper_figure(runs, OUT / "paper_figure.png", zoom_s=10)
display(Image(filename=str(fig_path)))

metrics = {model: tr.metrics() for model, tr in runs.items()}


def fmt(x, spec=".1f", none="—"):
    return none if x is None else format(x, spec)


md_table(
    ["model", "settling [s]", "overshoot [%]", "peak tilt [deg]", "time on tilt limit [%]", "final distance [m]"],
    [[model, fmt(m.settling_s), fmt(m.overshoot_pct), fmt(m.peak_tilt_deg),
      fmt(None if m.tilt_limit_fraction is None or model == "linear" else 100 * m.tilt_limit_fraction),
      f"{np.hypot(*runs[model].xy[-1]):.3f}"] for model, m in metrics.items()],
)
lin, red, full = metrics["linear"], metrics["reduced"], metrics["full"]
d_full = np.hypot(runs["full"].xy[:, 0], runs["full"].xy[:, 1])
w60 = int(round(60 / runs["full"].options.output_dt_s))
full_first60, full_last60 = float(d_full[:w60].max()), float(d_full[-w60:].max())
print(f"linear: settles at {lin.settling_s:.1f} s (envelope estimate {t_envelope:.0f} s), overshoot {lin.overshoot_pct:.1f} %, "
      f"peak commanded tilt {lin.peak_tilt_deg:.1f}° (no limit in this model)")
print(f"reduced: settles at {red.settling_s:.1f} s, overshoot {red.overshoot_pct:.1f} %")
print(f"full: max distance {full_first60:.2f} m in the first 60 s, {full_last60:.2f} m in the last 60 s; "
      f"tilt on its limit {100 * full.tilt_limit_fraction:.0f} % of the time")

# %% [markdown]
# The linear and reduced runs agree: with the paper's gains the tilt limit is
# reached only briefly at the start, and both ring for minutes with a
# period of a few seconds -- the opposite of "no oscillations or overshoot".
# On the full vehicle the same gains produce a *growing* oscillation.

# %% [markdown]
# ## Why the full vehicle diverges: the attitude loop's lag
#
# The attitude loop turns a commanded acceleration into tilt through
# ω_a²/(s² + 2ζ_a ω_a s + ω_a²) (`nniquad.control.inner_loops`; its defaults are
# printed below), roughly an effective delay 2ζ_a/ω_a.  The dominant pair's decay rate σ
# (printed above) is tiny, and the phase the lag adds at the dominant
# frequency is enough to push the pair into the right half-plane.  Below, the reduced linear
# loop is augmented with that second-order lag (a linearisation about hover;
# g tan θ ≈ g θ) and its dominant pole is followed as ω_a grows; the full
# nonlinear vehicle is then simulated for the same ω_a values (one batched run
# over the same horizon as the figure).

# %%
zeta_a = DEFAULT_INNER_LOOP_GAINS.attitude_zeta
wa_default = DEFAULT_INNER_LOOP_GAINS.attitude_wn_rad_s


def loop_with_attitude_lag(m, kp, Gamma, delta, wa, za):
    """One axis, states [ξ, ξ', z, a, a']: a follows a_cmd = -kp ξ + z/m through the attitude lag."""
    A = np.zeros((5, 5))
    A[0, 1] = 1.0
    A[1, 3] = 1.0
    A[2, 0], A[2, 2] = Gamma, -Gamma * delta
    A[3, 4] = 1.0
    A[4, 0], A[4, 2], A[4, 3], A[4, 4] = -kp * wa**2, wa**2 / m, -wa**2, -2 * za * wa
    return A


def dominant_real_part(wa):
    return float(np.max(np.linalg.eigvals(loop_with_attitude_lag(V.m, G.kp, G.Gamma, G.delta, wa, zeta_a)).real))


wa_crit = brentq(dominant_real_part, wa_default, 2000.0)
lag_s = 2 * zeta_a / wa_default
phase_lag_deg = math.degrees(lag_s * omega_dom)
print(f"default attitude loop (DEFAULT_INNER_LOOP_GAINS): ω_a = {wa_default:g} rad/s, ζ_a = {zeta_a:g}; "
      f"effective delay 2ζ_a/ω_a = {1000 * lag_s:.0f} ms, "
      f"phase lag at the dominant frequency ≈ {phase_lag_deg:.1f}°")
print(f"linearised: dominant real part {dominant_real_part(wa_default):+.4f} 1/s at ω_a = {wa_default:g}; "
      f"stable only for ω_a > {wa_crit:.1f} rad/s")

wa_grid = np.array([25.0, 40.0, 60.0, 70.0, 80.0, 90.0, 100.0, 150.0])
opt_full = SimOptions(model="full", horizon_s=PAPER_FIGURE_HORIZON_S)
# one batched call: the same gains, one option set per attitude bandwidth
res_wa = simulate(V, G, [opt_full.with_(inner=replace(DEFAULT_INNER_LOOP_GAINS, attitude_wn_rad_s=float(w)))
                           for w in wa_grid])
t_wa, dist_wa = res_wa.t, res_wa.distance
growth = dist_wa[:, -w60:].max(axis=1) / dist_wa[:, :w60].max(axis=1)
settle_wa = res_wa.settling_s
lin_re = np.array([dominant_real_part(w) for w in wa_grid])
md_table(["ω_a [rad/s]", "linearised max Re [1/s]", "full: max dist. last 60 s / first 60 s", "full: settling [s]"],
         [[f"{w:g}", f"{r:+.4f}", f"{g:.2f}", fmt(None if np.isnan(s) else s)]
          for w, r, g, s in zip(wa_grid, lin_re, growth, settle_wa)])
wa_full_stable = float(wa_grid[np.argmax(growth < 1.0)]) if np.any(growth < 1.0) else float("nan")

fig, ax = plt.subplots(1, 2, figsize=(11, 3.6))
wa_fine = np.linspace(20, 200, 200)
ax[0].plot(wa_fine, [dominant_real_part(w) for w in wa_fine])
ax[0].axhline(0, color="k", lw=0.6)
ax[0].axvline(wa_crit, color="tab:red", ls=":", label=f"ω_a = {wa_crit:.0f} rad/s")
ax[0].set_xlabel("attitude bandwidth ω_a [rad/s]")
ax[0].set_ylabel("dominant Re(pole) [1/s]")
ax[0].set_title("reduced loop + attitude lag (linearised)")
ax[0].legend()
blk = int(round(5.0 / opt_full.output_dt_s))  # envelope: largest distance in each 5 s block
n_blk = dist_wa.shape[1] // blk
t_blk = (np.arange(n_blk) + 0.5) * blk * opt_full.output_dt_s
env = dist_wa[:, : n_blk * blk].reshape(len(wa_grid), n_blk, blk).max(axis=2)
for w, e in zip(wa_grid, env):
    ax[1].semilogy(t_blk, e, lw=1.2, label=f"{w:g}")
ax[1].set_xlabel("time [s]")
ax[1].set_ylabel("largest ‖ξ_h‖ per 5 s [m], full model")
ax[1].set_title("full vehicle, paper's gains")
ax[1].legend(title="ω_a [rad/s]", fontsize=7, ncol=2)
fig.tight_layout()
show(fig)

# %% [markdown]
# The linearised loop and the full vehicle agree on where the paper's gains
# stop working: the full vehicle's oscillation shrinks only once ω_a is near
# the linearised threshold.  An attitude loop that fast is near what the
# motors allow (notebook 3 derives the limit a motor lag puts on ω_a), and even
# then the position loop only crawls back with the paper's damping; the gains,
# not the vehicle, need changing (notebook 2).

# %% [markdown]
# ## Certified region of attraction of the paper's gains
#
# For completeness: the saturated reduced loop (tilt limit, norm limit) has a
# certified ellipsoidal region of attraction (`nniquad.region_of_attraction`,
# generalised sector condition).  It covers the paper's start, but it says
# nothing about the attitude dynamics that break the full vehicle.

# %%
u0 = axis_acceleration_limit(V.g, TILT_LIMIT_DEG)
roa_paper = region_of_attraction(LOOP, u0)
reach_paper = roa_paper.values["max_displacement_m"]
xi0_norm = math.hypot(*XI0_M)
print(f"u0 = {u0:.3f} m/s²; certified reach from rest {reach_paper:.2f} m (feasible: {roa_paper.feasible}); "
      f"the paper's start is at {xi0_norm:.2f} m")

# %% [markdown]
# ## The audit's verdicts on the simulation section

# %%

sim_audit = audit(section="simulation")
md_table(["claim", "verdict", "reason"], [[r.id, f"**{r.verdict}**", r.reason] for r in sim_audit])
verdicts = {r.id: r.verdict for r in sim_audit}
for r in sim_audit:
    if isinstance(r.correction, dict):
        for k, v in r.correction.items():
            if isinstance(v, str):
                print(f"[{r.id}] {k}: {v}")

# %%
# conclusion -- every number below was computed in this notebook
elapsed = time.perf_counter() - T_START
n_fail = sum(v == "fails" for v in verdicts.values())
print("Conclusion")
print(f"- The paper's arithmetic holds: δ_min = {delta_min:.2f} for γ = {GAMMA_PAPER}, and δ = {G.delta:g} satisfies it "
      f"(the gains in fact satisfy the bound for any γ ≥ {gamma_needed:.3f}).")
print(f"- The sector bound guarantees stability, not damping: the closed loop has a fast pole at {fast_pole:.0f} 1/s "
      f"and a dominant pair {-sigma_dom:.4f} ± {omega_dom:.3f}j with ζ = {pdmp.min_damping:.4f}.")
print(f"- The missing figure therefore shows a slowly decaying oscillation, not a smooth approach: on the linear "
      f"model the position overshoots by {lin.overshoot_pct:.0f} % and settles (2 % band) only after "
      f"{lin.settling_s:.0f} s (the tilt-limited reduced model: {red.settling_s:.0f} s).")
print(f"- On the full vehicle with the default attitude loop (ω_a = {wa_default:g} rad/s, ~{1000 * lag_s:.0f} ms lag) "
      f"the same gains diverge: the distance grows from {full_first60:.1f} m to {full_last60:.1f} m over "
      f"{PAPER_FIGURE_HORIZON_S:.0f} s with the tilt saturated {100 * full.tilt_limit_fraction:.0f} % of the time. "
      f"The linearised loop with the attitude lag is stable only for ω_a > {wa_crit:.0f} rad/s; in the full "
      f"simulation the oscillation first shrinks at ω_a = {wa_full_stable:g} rad/s.")
print(f"- Audit of the simulation section: {', '.join(f'{k}: {v}' for k, v in verdicts.items())} "
      f"({n_fail} claim(s) fail as printed).")
print(f"(notebook ran in {elapsed:.0f} s)")
