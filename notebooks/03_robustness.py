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
# # 3 · Robustness of a certified design on the full vehicle
#
# A gain set that satisfies the sector bound is certified for the *reduced*
# horizontal loop.  The real vehicle adds what the theorem leaves out: a mass
# the controller does not know exactly, an attitude loop of finite bandwidth,
# motors that lag, and wind.  This notebook takes one certified gain set, tuned
# on the `full` model with motor lag, and varies each of these in turn until
# the design breaks; for each break it computes from the vehicle data *why* it
# breaks there.
#
# All runs use the `full` model (12 states, inner loops, rotor saturation,
# first-order motor lag) from the paper's initial state ξ_h(0) at rest, over a
# horizon long enough to see slow failures such as a lost altitude.

# %%
import math
import time
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np
from scipy.optimize import brentq

from nniquad import (
    attitude_accel_headroom,
    attitude_wn_cap,
    certified_reach,
    max_horizontal_acceleration,
    notebook_vehicle,
    notebook_certificate,
    notebook_data,
    ReducedLoop,
    required_hold_s,
    show_figure as show,
    show_table as md_table,
    SimOptions,
    simulate,
    TuneOptions,
    XI0_M,
)


T_START = time.perf_counter()
V = notebook_vehicle()  # the file $NNIQUAD_VEHICLE names (TOML or JSON); unset: the paper's vehicle
GAMMA_MAX = TuneOptions().gamma_max
XI0_NORM = math.hypot(*XI0_M)
HORIZON_S = 20.0






def fmt(x, spec=".2f", none="—"):
    return none if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, spec)


# %% [markdown]
# ## The design under test
#
# The gain set below is the certificate `notebooks/data/full_model_certificate.json`,
# written by `nniquad certify --model full` (the tuner's defaults: the robust
# objective over the 20 tuning scenarios, the `"normal"` budget, seed 0).  That
# tune takes about two minutes, too long for this notebook, so the certificate is read (its digest checked); everything
# the notebook says about it is recomputed: the sector bound, the certified
# reach and the nominal settling time.

# %%
# tuned and written by `nniquad certify --model full --out notebooks/data/full_model_certificate.json`,
# re-certified with the current code (same gains and tuning record) by `nniquad certify --model full
# --gains-from notebooks/data/full_model_certificate.json --out notebooks/data/full_model_certificate.json`;
# notebook_certificate reads notebooks/data whatever the working folder, checks the schema and SHA-256 digest,
# and refuses a certificate of another vehicle than V
CERT = notebook_certificate("full_model_certificate.json", vehicle=V)
GAINS = CERT.gains
INNER = CERT.inner_loop
BASE = SimOptions(model="full", horizon_s=HORIZON_S, motor_lag=True, inner=INNER)
TILT = BASE.tilt_limit_deg

gamma_used = ReducedLoop.from_vehicle(V, GAINS).smallest_gamma
reach = certified_reach(ReducedLoop.from_vehicle(V, GAINS), TILT)
nominal = simulate(V, GAINS, BASE)[0]
nom = nominal.metrics()
nom_reduced = simulate(V, GAINS, SimOptions(model="reduced", horizon_s=HORIZON_S))[0].metrics()
wa0, za0, tau0 = INNER.attitude_wn_rad_s, INNER.attitude_zeta, V.tau_motor
print(f"gains kp = {GAINS.kp:.4g} 1/s², Γ = {GAINS.Gamma:.4g}, δ = {GAINS.delta:.4g}; attitude loop ω_a = {wa0:.4g} rad/s, "
      f"ζ_a = {za0:.3f}, α = {INNER.attitude_accel_limit_rad_s2:.3g} rad/s²")
print(f"sector bound: smallest γ = {gamma_used:.4f} ≤ γ_max = {GAMMA_MAX:g}: {gamma_used <= GAMMA_MAX}; "
      f"certified reach {reach:.2f} m (start at {XI0_NORM:g} m)")
print(f"nominal full model with motor lag (τ = {1000 * tau0:g} ms): settles in {nom.settling_s:.3f} s, overshoot "
      f"{nom.overshoot_pct:.1f} %, peak tilt {nom.peak_tilt_deg:.1f}°, peak rotor speed {nom.peak_rotor_speed_rad_s:.0f} "
      f"of {V.omega_max:g} rad/s, altitude deviation {100 * nom.altitude_dev_m:.1f} cm; reduced model: {nom_reduced.settling_s:.3f} s")
# the certificate's own reference run (its rate, start and output period: cert.run_settings()) is what it states
REF = CERT.run_settings()
ref = REF.simulate()[0].metrics()
print(f"the certificate's reference run performance.full ({REF.options.sampling} law at {REF.options.rate_hz:g} Hz): "
      f"settles in {ref.settling_s:.4f} s (stated {REF.stated['settling_s']:.4f} s); the runs below use the "
      f"{BASE.sampling} law of the paper's model")

# %% [markdown]
# **What the tuner guards against.**  One condition explains what follows in
# several sections.  Near hover, one attitude axis with the PD law of
# `nniquad.control.inner_loops` and a first-order motor lag τ on the torque obeys
# τ s³ + s² + 2ζ_a ω_a s + ω_a² = 0, whose Routh condition is
# **ω_a τ < 2 ζ_a**.  Above it, hover itself is unstable: the attitude
# oscillates in a limit cycle bounded only by rotor saturation, and the rotors
# chatter between their limits.  The tuner therefore caps ω_a at ζ_a/(2τ)
# (`nniquad.tuning.tune.attitude_wn_cap`: the Routh limit for a motor twice as
# slow as nominal, with a further factor 2 of gain margin), so the line is
# crossed only by a motor four times slower than the vehicle's.  And it counts
# a settling time only if the run is then seen inside the band for
# max(5 s, 2 × settling) within its horizon (`settling_shown`): a set that only
# looks settled on a short horizon is "did not settle".

# %%
def attitude_margin(wa, za, tau):
    """2 ζ_a / (ω_a τ): above 1 the linearised attitude loop with motor lag is stable."""
    return 2.0 * za / (wa * tau)


def hover_poles(wa, za, tau):
    return np.roots([tau, 1.0, 2.0 * za * wa, wa**2])


def chatter(traj, window_s=5.0):
    """Largest standard deviation of a rotor speed over the last window [rad/s]."""
    n = int(round(window_s / traj.options.output_dt_s))
    return float(traj.rotor_speeds[-n:].std(axis=0).max())


#: A run whose rotor speeds still swing by more than this at the end is not flyable [rad/s].
CHATTER_OK = 0.02 * V.omega_max
wa_cap = attitude_wn_cap(tau0, za0)
ref_margin = attitude_margin(wa0, za0, tau0)
hold = required_hold_s(nom.settling_s)
md_table(["design", "ω_a [rad/s]", "tuner's cap ζ_a/(2τ) [rad/s]", "2ζ_a/(ω_a τ)", "max Re hover pole [1/s]",
          f"settling over {HORIZON_S:g} s", "required hold [s]", "rotor chatter, last 5 s [rad/s]"],
         [["reference (normal budget)", f"{wa0:.4g}", f"{wa_cap:.4g}", f"{ref_margin:.3f}",
           f"{hover_poles(wa0, za0, tau0).real.max():+.2f}", fmt(nom.settling_s, ".3f"), f"{hold:g}",
           f"{chatter(nominal):.1f}"]])
print(f"the design's attitude loop tolerates a motor up to {1000 * 2 * za0 / wa0:.0f} ms "
      f"({2 * za0 / (wa0 * tau0):.1f} × the nominal {1000 * tau0:g} ms); its settling {nom.settling_s:.2f} s is "
      f"shown with {HORIZON_S - nom.settling_s:.1f} s in the band after it (needed: {hold:g} s)")

# %% [markdown]
# ## 1 · Mass mismatch
#
# The controller keeps its nominal mass m̂ while the true mass varies.  The
# horizontal loop itself does not care much: the command is an acceleration,
# realised with m̂, so the plant sees the gain scaled by m̂/m, which leaves
# the Routh condition m̂ k_p δ > 1 unchanged.  What limits a heavier vehicle is
# thrust.  Three masses follow from the vehicle data:
#
# * hover at all: 4 b ω_max² = m g;
# * hover at the tilt limit: 4 b ω_max² cos T_lim = m g;
# * keep the roll/pitch angular acceleration α that the attitude loop was
#   tuned to use when reversing the tilt at the limit
#   (`nniquad.tuning.tune.attitude_accel_headroom`: the pair difference a rotor can
#   still add is T_max − m g/(4 cos T_lim)).

# %%
T_max_total = V.max_thrust()
m_hover = T_max_total / V.g
m_tilt = T_max_total * math.cos(math.radians(TILT)) / V.g
alpha_design = INNER.attitude_accel_limit_rad_s2
m_alpha = brentq(lambda mm: attitude_accel_headroom(V.with_(m=mm), TILT) - alpha_design, V.m, m_tilt)
print(f"ω_max = {V.omega_max:g} rad/s, b = {V.b:.4g} N s² → total thrust {T_max_total:.3f} N")
print(f"hover limit {m_hover:.3f} kg; hover at the {TILT:g}° tilt limit {m_tilt:.3f} kg; "
      f"torque headroom at the limit falls below α = {alpha_design:.3g} rad/s² above {m_alpha:.3f} kg")

MASSES = np.round(np.arange(0.30, 1.0001, 0.05), 2)
mass_runs = {float(mm): simulate(V, GAINS, BASE.with_(true_mass_kg=float(mm)))[0] for mm in MASSES}
mass_met = {mm: tr.metrics() for mm, tr in mass_runs.items()}
md_table(["true mass [kg]", "settling [s]", "overshoot [%]", "peak rotor speed [rad/s]", "altitude deviation [m]",
          "final distance [m]"],
         [[f"{mm:.2f}", fmt(m.settling_s), fmt(m.overshoot_pct, ".1f"), f"{m.peak_rotor_speed_rad_s:.0f}",
           f"{m.altitude_dev_m:.2f}", f"{np.hypot(*mass_runs[mm].xy[-1]):.3f}"] for mm, m in mass_met.items()])
ok_mass = [mm for mm, m in mass_met.items() if m.settling_s is not None and m.altitude_dev_m < 1.0]
m_break = min((mm for mm in mass_met if mm > V.m and mm not in ok_mass), default=float("nan"))
m_last_ok = max(mm for mm in ok_mass if mm < m_break) if math.isfinite(m_break) else max(ok_mass)
m_first_ok = min(ok_mass)
print(f"works (settles, altitude within 1 m) from {m_first_ok:.2f} kg to {m_last_ok:.2f} kg; first failure at {m_break:.2f} kg")
if m_break > m_tilt:
    mass_why = (f"It fails between hover at the tilt limit ({m_tilt:.3f} kg) and the hover limit ({m_hover:.3f} kg): "
                f"the vehicle can hover level, but not at the {TILT:g}° tilt the horizontal loop commands, so it sinks "
                f"while it accelerates.  The torque headroom (below α = {alpha_design:.0f} rad/s² above "
                f"{m_alpha:.3f} kg) does not cost altitude: the allocation keeps the collective and gives way on roll/pitch.")
elif m_break > m_alpha:
    mass_why = (f"Not the hover limit ({m_hover:.3f} kg) nor hover at the tilt limit ({m_tilt:.3f} kg) but the torque "
                f"headroom: above {m_alpha:.3f} kg the rotors cannot give the α = {alpha_design:.0f} rad/s² the "
                f"attitude loop plans with at {TILT:g}° tilt.")
else:
    mass_why = f"It fails below every thrust limit computed above ({m_alpha:.3f}, {m_tilt:.3f}, {m_hover:.3f} kg)."
print(mass_why)

# %% [markdown]
# ## 2 · Attitude-loop bandwidth
#
# The attitude natural frequency ω_a is varied with everything else fixed.  A
# slower attitude loop delays the tilt the NNI loop asks for, which costs
# damping of the position loop (notebook 1 showed that the paper's gains
# diverge for this reason); a faster one crosses ω_a τ = 2ζ_a.

# %%
WA = np.array([10, 15, 20, 25, 30, 40, 50, 60, 80, 90, wa0, 105, 110, 120, 150, 200], dtype=float)
wa_runs = {w: simulate(V, GAINS, BASE.with_(inner=replace(INNER, attitude_wn_rad_s=float(w))))[0] for w in WA}
wa_met = {w: tr.metrics() for w, tr in wa_runs.items()}
wa_crit = 2.0 * za0 / tau0
md_table(["ω_a [rad/s]", "2ζ_a/(ω_a τ)", "settling [s]", "overshoot [%]", "altitude deviation [m]", "rotor chatter [rad/s]"],
         [[f"{w:.4g}", f"{attitude_margin(w, za0, tau0):.2f}", fmt(m.settling_s), fmt(m.overshoot_pct, ".1f"),
           f"{m.altitude_dev_m:.2f}", f"{chatter(wa_runs[w]):.1f}"] for w, m in wa_met.items()])
wa_ok = [w for w, m in wa_met.items()
         if m.settling_s is not None and m.altitude_dev_m < 1.0 and chatter(wa_runs[w]) < CHATTER_OK]
wa_bad_hi = min((w for w in WA if w > wa0 and w not in wa_ok), default=float("nan"))
wa_ok_hi = max(w for w in wa_ok if w < wa_bad_hi) if math.isfinite(wa_bad_hi) else max(wa_ok)
wa_slowest = min(wa_ok)
print(f"Routh limit ω_a < 2ζ_a/τ = {wa_crit:.1f} rad/s (the design uses {wa0:.1f}); works up to {wa_ok_hi:.4g}, "
      f"fails from {wa_bad_hi:.4g} rad/s (works = settles, altitude within 1 m, rotor chatter below "
      f"{CHATTER_OK:.0f} rad/s); the slowest that works, {wa_slowest:g} rad/s, settles in "
      f"{wa_met[wa_slowest].settling_s:.1f} s")

# %% [markdown]
# ## 3 · Motor lag
#
# The motor time constant τ is varied (the vehicle's is the nominal value).
# The same Routh condition, read the other way, gives the largest lag the
# attitude loop tolerates: τ < 2ζ_a/ω_a.

# %%
TAUS = np.array([0.005, 0.01, 0.015, 0.02, 0.022, 0.025, 0.03, 0.04, 0.06, 0.1])
tau_runs = {t: simulate(V, GAINS, BASE.with_(tau_motor_s=float(t)))[0] for t in TAUS}
nolag = simulate(V, GAINS, BASE.with_(motor_lag=False))[0]
tau_met = {t: tr.metrics() for t, tr in tau_runs.items()}
tau_crit = 2.0 * za0 / wa0
nl = nolag.metrics()
md_table(["τ [ms]", "2ζ_a/(ω_a τ)", "settling [s]", "overshoot [%]", "peak tilt [deg]", "altitude deviation [m]",
          "rotor chatter [rad/s]"],
         [[f"{1000 * t:g}", f"{attitude_margin(wa0, za0, t):.2f}", fmt(m.settling_s), fmt(m.overshoot_pct, ".1f"),
           f"{m.peak_tilt_deg:.1f}", f"{m.altitude_dev_m:.2f}", f"{chatter(tau_runs[t]):.1f}"] for t, m in tau_met.items()]
         + [["no lag", "∞", fmt(nl.settling_s), fmt(nl.overshoot_pct, ".1f"), f"{nl.peak_tilt_deg:.1f}",
             f"{nl.altitude_dev_m:.2f}", f"{chatter(nolag):.1f}"]])
tau_ok = [t for t, m in tau_met.items()
          if m.settling_s is not None and m.altitude_dev_m < 1.0 and chatter(tau_runs[t]) < CHATTER_OK]
tau_bad = min((t for t in TAUS if t not in tau_ok), default=float("nan"))
tau_ok_hi = max(t for t in tau_ok if t < tau_bad) if math.isfinite(tau_bad) else max(tau_ok)
print(f"Routh limit τ < 2ζ_a/ω_a = {1000 * tau_crit:.1f} ms (nominal {1000 * tau0:g} ms); works up to "
      f"{1000 * tau_ok_hi:g} ms, fails from {1000 * tau_bad:g} ms")
print(f"without motor lag the same gains settle in {nl.settling_s:.2f} s, with the nominal lag in {nom.settling_s:.2f} s")

# %% [markdown]
# ## 4 · Wind
#
# A constant horizontal force F (north) is applied.  The NNI controller has
# no integrator: in steady state its state is z = ξ/δ, so per axis
# 0 = −m k_p ξ + ξ/δ + F, i.e. an offset ξ = F δ/(m k_p δ − 1).  The positive
# feedback that makes the controller NNI *lowers* the static stiffness from
# m k_p to m k_p (1 − γ), with γ = 1/(m k_p δ) the smallest admissible sector
# constant.  And the vehicle can only push back with its tilt-limited
# acceleration: F_max = m a_max (`nniquad.analysis.bound.max_horizontal_acceleration`).

# %%
a_max = max_horizontal_acceleration(V, TILT)
F_max = V.m * a_max
compliance = GAINS.delta / (V.m * GAINS.kp * GAINS.delta - 1.0)
compliance_p = 1.0 / (V.m * GAINS.kp)
WIND = np.round(np.concatenate([np.linspace(0.0, 2.5, 6), [2.7, 2.8, 3.0, 3.5]]), 3)
wind_runs = {float(F): simulate(V, GAINS, BASE.with_(wind_N=(float(F), 0.0)))[0] for F in WIND}
wind_final = {F: float(np.hypot(*tr.xy[-1])) for F, tr in wind_runs.items()}
wind_met = {F: tr.metrics() for F, tr in wind_runs.items()}
md_table(["F [N]", "F / F_max", "predicted offset [m]", "final distance [m]", "time on tilt limit [%]"],
         [[f"{F:g}", f"{F / F_max:.2f}", f"{compliance * F:.3f}" if F < F_max else "none",
           f"{wind_final[F]:.3f}", f"{100 * wind_met[F].tilt_limit_fraction:.0f}"] for F in wind_final])
held = [F for F in wind_final if F < F_max and abs(wind_final[F] - compliance * F) < 0.05 + 0.05 * compliance * F]
F_ok = max(held)
F_bad = min(F for F in wind_final if F not in held and F > F_ok)
print(f"static compliance {compliance:.3f} m/N with the NNI controller, {compliance_p:.3f} m/N for the kp loop alone "
      f"({compliance / compliance_p:.1f} × = 1/(1 − γ))")
print(f"a_max = {a_max:.3f} m/s² → F_max = {F_max:.3f} N; held (offset as predicted) up to {F_ok:g} N, lost at {F_bad:g} N")

# %%
fig, ax = plt.subplots(2, 2, figsize=(12, 8))


def settle_plot(a, x, mets, xlabel, logx=False):
    s = np.array([np.nan if m.settling_s is None else m.settling_s for m in mets])
    ok = np.isfinite(s)
    a.plot(np.asarray(x)[ok], s[ok], "o-", label="settling time")
    top = HORIZON_S
    a.plot(np.asarray(x)[~ok], np.full((~ok).sum(), top), "rx", ms=9, label=f"not settled in {HORIZON_S:g} s")
    a.set_xlabel(xlabel)
    a.set_ylabel("settling time [s]")
    a.set_yscale("log")
    if logx:
        a.set_xscale("log")


a = ax[0, 0]
settle_plot(a, list(mass_met), list(mass_met.values()), "true mass [kg]")
for mm, ls, lab in ((m_alpha, ":", "torque headroom < α"), (m_tilt, "--", "hover at tilt limit"),
                    (m_hover, "-", "hover limit")):
    a.axvline(mm, color="k", ls=ls, lw=1, label=f"{lab}: {mm:.3f} kg")
a.axvline(V.m, color="tab:green", lw=1, label=f"nominal {V.m:g} kg")
a.legend(fontsize=7)
a = ax[0, 1]
settle_plot(a, WA, list(wa_met.values()), "attitude natural frequency ω_a [rad/s]", logx=True)
a.axvline(wa_crit, color="k", ls=":", label=f"ω_a = 2ζ_a/τ = {wa_crit:.0f} rad/s")
a.axvline(wa0, color="tab:green", lw=1, label=f"design {wa0:.0f} rad/s")
a.legend(fontsize=7)
a = ax[1, 0]
settle_plot(a, 1000 * TAUS, list(tau_met.values()), "motor time constant τ [ms]", logx=True)
a.axvline(1000 * tau_crit, color="k", ls=":", label=f"τ = 2ζ_a/ω_a = {1000 * tau_crit:.1f} ms")
a.axvline(1000 * tau0, color="tab:green", lw=1, label=f"nominal {1000 * tau0:g} ms")
a.legend(fontsize=7)
a = ax[1, 1]
Fs = np.array(list(wind_final))
a.plot(Fs, [wind_final[F] for F in Fs], "o", label="simulated final distance")
Fl = np.linspace(0, F_max, 50)
a.plot(Fl, compliance * Fl, "-", label="offset F δ/(m k_p δ − 1)")
a.plot(Fl, compliance_p * Fl, "--", label="offset without the NNI controller, F/(m k_p)")
a.axvline(F_max, color="k", ls=":", label=f"F_max = m a_max = {F_max:.2f} N")
a.set_yscale("symlog", linthresh=1.0)
a.set_ylim(bottom=0.0)
a.set_xlabel("wind force F [N]")
a.set_ylabel(f"distance at t = {HORIZON_S:g} s [m]")
a.legend(fontsize=7)
fig.tight_layout()
show(fig)

# %% [markdown]
# ## How the failures look
#
# The first failing run of three sweeps: the heavy vehicle (altitude and mean
# rotor speed), the motor lag beyond the attitude loop's tolerance (the rotor
# speeds at the end), and the wind close to F_max (the position runs away).

# %%
tr_mass = mass_runs[m_break]
tr_tau = tau_runs[tau_bad]
tr_wind = wind_runs[F_bad]
fig, ax = plt.subplots(1, 3, figsize=(14, 3.8))
a = ax[0]
a.plot(tr_mass.t, -tr_mass.z_ned, color="k", label="height change [m]")
a.set_xlabel("time [s]")
a.set_ylabel("height change [m]")
a2 = a.twinx()
a2.plot(tr_mass.t, tr_mass.rotor_speeds.mean(axis=1), color="tab:orange", lw=0.8, label="mean rotor speed")
a2.axhline(V.omega_max, color="tab:red", ls=":", label="ω_max")
a2.set_ylabel("rotor speed [rad/s]")
a.set_title(f"true mass {m_break:.2f} kg")
a2.legend(fontsize=7, loc="lower right")
a = ax[1]
w_end = tr_tau.t > tr_tau.t[-1] - 0.5
a.plot(tr_tau.t[w_end], tr_tau.rotor_speeds[w_end], lw=0.8)
a.axhline(V.omega_max, color="tab:red", ls=":")
a.set_xlabel("time [s]")
a.set_ylabel("rotor speeds [rad/s]")
a.set_title(f"τ = {1000 * tau_bad:g} ms: last 0.5 s")
a = ax[2]
a.plot(tr_wind.t, tr_wind.xy[:, 0], label="x (north)")
a.plot(tr_wind.t, tr_wind.xy[:, 1], label="y (east)")
a.set_xlabel("time [s]")
a.set_ylabel("position [m]")
a.set_title(f"wind {F_bad:g} N = {F_bad / F_max:.2f} F_max")
a.legend(fontsize=7)
fig.tight_layout()
show(fig)
w = tr_tau.rotor_speeds[w_end, 0] - tr_tau.rotor_speeds[w_end, 0].mean()
spec = np.abs(np.fft.rfft(w))
freqs = np.fft.rfftfreq(len(w), tr_tau.options.output_dt_s)
f_chatter = float(freqs[1:][np.argmax(spec[1:])])
print(f"rotor speeds at τ = {1000 * tau_bad:g} ms, last 0.5 s: dominant frequency ≈ {f_chatter:.0f} Hz, "
      f"peak-to-peak {np.ptp(tr_tau.rotor_speeds[w_end], axis=0).max():.0f} rad/s")

# %% [markdown]
# ## 5 · Six laws on the same scenarios: which wins where
#
# The certified velocity-free laws -- the NNI law in each of its two law
# classes and the second-order SNI law (`sni2`) in each class -- are
# compared with the two PD laws of notebook 04 (true velocity; derivative
# filtered from the measured position), each tuned by the same tuner on the
# same inner loops, scenario set and rules, every candidate run as it flies
# (position sampled at 100 Hz, the law in discrete time).  The certified
# designs are certificates: the `paper` class (the sector bound holds; the one
# above), the `cascade` class (the sector bound dropped, the sampled-data
# cascade certificate alone), the NNI designs seeded with the image of a filtered PD of
# their class (section 6); the `sni2` paper-class design is tuned unseeded
# (docs/notes/laws.md: at the sector bound its loop can decay √5 times faster than
# the NNI law's at the same stiffness).
#
# A single design per law is one point; a trade-off needs a family.  Each
# design is therefore also run λ times faster and slower (`time_scaled(λ)`:
# the same horizontal loop on the time scale t/λ -- for NNI k_p λ², Γ λ³,
# δ/λ², which keeps the sector bound; the attitude loop stays as tuned, so
# λ > 1 asks more of it).  Time scaling keeps the sector bound, so every
# member of the paper-class families (NNI and SNI2; for SNI2 k λ⁴, ω λ keep
# k/(m k_p ω²)) is certified by the theorem; in the
# cascade class only λ = 1 is a certified design (the cascade
# certificate is computed per design), the other members are the same law
# run faster or slower.  Every member gets two numbers: its nominal settling
# time on the full vehicle with the position sampled at 100 Hz (counted only
# if the run is then seen in the band for the required hold), and its success
# rate over the same Monte Carlo scenarios (default ranges, a seed the tuner
# never saw).  The front of a law is its set of non-dominated members
# (`pareto_front`).
#
# The designs, certificates and these families (a few hundred full-model
# runs) are computed by `python notebooks/data/make_data.py` (its docstring
# lists every command; the families are its step `families`, which records
# the SHA-256 of each design file it read); this section reads them.

# %%
import hashlib
import json

from nniquad import InnerLoopGains, pareto_front, PDFilteredGains

DATA = notebook_data()  # notebooks/data of this checkout (or $NNIQUAD_NOTEBOOK_DATA), never the working folder
FAMILIES = json.loads((DATA / "families.json").read_text())
LAWS = tuple(FAMILIES["designs"])
LAW_LABEL = {"nni": "NNI, paper class (certified)", "nni_cascade": "NNI, cascade class (certified)",
             "sni2_cascade": "SNI2, cascade class (certified)", "sni2_paper": "SNI2, paper class (certified)",
             "pd_velocity": "PD, true velocity", "pd_filtered": "PD, filtered derivative"}
LAW_COLOR = {"nni": "tab:blue", "nni_cascade": "tab:purple", "sni2_cascade": "tab:red", "sni2_paper": "tab:brown",
             "pd_velocity": "tab:green",
             "pd_filtered": "tab:orange"}
for law, d in FAMILIES["designs"].items():  # a families file computed from other designs is stale
    assert hashlib.sha256((DATA / d["file"]).read_bytes()).hexdigest() == d["sha256"], \
        f"{DATA / 'families.json'} is older than {d['file']}: run make_data.py families"
# written by `nniquad certify --model full --warm-start designs/pd_filtered_paper.json ...` (make_data.py, nni_paper)
PAPER_CERT = notebook_certificate("paper_model_certificate.json", vehicle=V)
# written by `nniquad certify --model full --law-class cascade ...` (make_data.py, step nni_cascade)
CASCADE_CERT = notebook_certificate("cascade_model_certificate.json", vehicle=V)
# written by `nniquad certify --model full --controller sni2 --law-class cascade ...` (step sni2_cascade)
SNI2_CERT = notebook_certificate("sni2_cascade_certificate.json", vehicle=V)
N_MC, MC_SEED = FAMILIES["samples"], FAMILIES["seed"]
family = [{"law": r["law"], "lam": r["lam"], "gains": r["gains"], "nominal_s": r["nominal_s"],
           "tilt": r["peak_tilt_deg"], "success": r["success"], "ci": tuple(r["success_ci"]), "p95": r["p95_s"]}
          for r in FAMILIES["rows"]]

md_table(["law", "λ", "gains", "nominal settling [s]", "nominal peak tilt [deg]",
          f"success over {N_MC} [%] (Wilson 95 %)", "p95 settling [s]"],
         [[LAW_LABEL[r["law"]], f"{r['lam']:g}", ", ".join(f"{k} {v:.3g}" for k, v in r["gains"].items()
                                                             if k != "kpy"),
           fmt(r["nominal_s"], ".2f"), fmt(r["tilt"], ".1f"),
           f"{100 * r['success']:.0f} [{100 * r['ci'][0]:.0f}, {100 * r['ci'][1]:.0f}]",
           fmt(r["p95"], ".2f")] for r in family])

# %%
fig, ax = plt.subplots(figsize=(7.5, 4.5))
fronts = {}
for law in LAWS:
    rows = [r for r in family if r["law"] == law]
    xs = [math.nan if r["nominal_s"] is None else r["nominal_s"] for r in rows]
    ys = [100 * r["success"] for r in rows]
    err = np.clip([[100 * (r["success"] - r["ci"][0]) for r in rows],
                   [100 * (r["ci"][1] - r["success"]) for r in rows]], 0.0, None)  # rounding at 0 / 100 %
    ax.errorbar(xs, ys, yerr=err, fmt="o", color=LAW_COLOR[law], alpha=0.45, capsize=2)
    idx = pareto_front([r["nominal_s"] for r in rows], [r["success"] for r in rows])
    fronts[law] = [rows[i] for i in idx]
    ax.plot([rows[i]["nominal_s"] for i in idx], [100 * rows[i]["success"] for i in idx], "-o",
            color=LAW_COLOR[law], label=LAW_LABEL[law])
    for r in rows:
        if r["nominal_s"] is not None:
            ax.annotate(f"λ={r['lam']:g}", (r["nominal_s"], 100 * r["success"]), fontsize=7,
                        xytext=(3, -9), textcoords="offset points")
ax.set_xlabel("nominal settling time, 100 Hz sampling [s]")
ax.set_ylabel(f"Monte Carlo success [%] ({N_MC} scenarios, seed {MC_SEED})")
ax.set_title(f"Pareto fronts of the {len(LAWS)} laws (time-scaled families of each tuned design)")
ax.legend(fontsize=8)
fig.tight_layout()
show(fig)

# %% [markdown]
# Which law wins where is read off the fronts: at each required success rate,
# the law whose front reaches it with the shortest nominal settling time.  With
# `N_MC` scenarios per point the Wilson intervals are wide (24 of 24 still
# allows a true rate of about 86 %), so the table says which law is fastest at
# a level, not by how much it is more robust.  The PD law with the true
# velocity has a sensor the others lack; the fair contest for a
# velocity-free vehicle is the certified laws against the filtered-derivative PD, so the
# table is given twice.

# %%
def fastest_at(level, laws=LAWS):
    """The fastest front member with success >= level, per law (of ``laws``)."""
    out = {}
    for law, front in fronts.items():
        if law not in laws:
            continue
        ok = [r for r in front if r["success"] >= level]
        if ok:
            out[law] = min(ok, key=lambda r: r["nominal_s"])
    return out


LEVELS = sorted({r["success"] for r in family if r["nominal_s"] is not None})


def winners(laws):
    """Rows [level, fastest law, its settling, runner-up] for each success level some law reaches."""
    rows = []
    for level in LEVELS:
        best = fastest_at(level, laws)
        if not best:
            continue
        law = min(best, key=lambda k: best[k]["nominal_s"])
        r = best[law]
        others = [best[k] for k in best if k != law]
        runner = min(others, key=lambda x: x["nominal_s"]) if others else None
        rows.append([f"{100 * level:.0f}", LAW_LABEL[law], f"{r['nominal_s']:.2f} (λ={r['lam']:g})",
                     "— (no other law reaches it)" if runner is None
                     else f"{LAW_LABEL[runner['law']]}: {runner['nominal_s']:.2f} s"])
    return rows


VELOCITY_FREE = tuple(law for law in LAWS if law != "pd_velocity")
winner_rows = winners(LAWS)
winner_rows_vf = winners(VELOCITY_FREE)
header = ["success at least [%]", "fastest law", "its nominal settling [s]", "runner-up"]
md_table(header, winner_rows)
md_table(header, winner_rows_vf)
overall = {law: max(front, key=lambda r: (r["success"], -r["nominal_s"])) for law, front in fronts.items() if front}
for law, r in overall.items():
    print(f"{LAW_LABEL[law]}: most robust front member λ = {r['lam']:g}: {100 * r['success']:.0f} % "
          f"[{100 * r['ci'][0]:.0f}, {100 * r['ci'][1]:.0f}], nominal {r['nominal_s']:.2f} s")

# %% [markdown]
# ## 6 · The filtered PD is the NNI law: which constraint costs the speed
#
# With the project's conventions (a_h = −k_p' ξ + z/m̂, ż = −Γδ z + Γ ξ), the
# PD law with a filtered derivative, a_h = −k_p ξ − k_d s/(τ_f s + 1) ξ, *is*
# the NNI law with k_p' = k_p + k_d/τ_f, Γ = m̂ k_d/τ_f², δ = τ_f/(m̂ k_d)
# (`nni_from_filtered_pd`; the audit's extension `filtered-pd-is-nni` checks
# it with sympy, and `tests/test_pd_equivalence.py` runs both laws from the
# same start to round-off).  So every filtered PD of section 5 is an NNI
# design, and the two laws differ only in what the tuner demands of them.
# Below, each demand is checked on the NNI image of the tuned filtered PDs
# (without a class, and restricted to each law class) and on the two
# certified NNI designs:
#
# * the **sector bound** δ ≥ 1/(γ_max m̂ k_p'), which under the map reads
#   (k_p τ_f/k_d + 1) γ_max ≥ 1 (γ_max = 0.8: k_p τ_f/k_d ≥ 1/4);
# * the **search box** `gain_limits`: k_p' ≤ k_p,max (the 5 cm band and the
#   attitude bandwidth) and Γδ ≤ π f_s (the sampling);
# * the **gain margins** GM ≥ 6 dB both ways at both break points (the phase
#   margins are reported only);
# * the **sampled-data cascade certificate** over the Monte Carlo box.
#
# The robust p95 is each tuning's own figure (the same 20 scenarios, the
# discrete controller at 100 Hz).

# %%
from nniquad import design_margins, gain_limits, LAW_CLASSES, margin_shortfall, nni_from_filtered_pd
from nniquad.laws import law_named

LIM = gain_limits(V, TILT)
GD_MAX = LIM["gamma_delta_max"]
# written by `nniquad certify --law-class cascade --gains-from designs/pd_filtered.json` (make_data.py, pd_image)
IMAGE_CERT = notebook_certificate("designs", "pd_filtered_image_certificate.json", vehicle=V)


def design_record(name):
    """(gains, inner loops, 'tune --json' record) of designs/<name>.json (the law is the file's)."""
    rec = json.loads((DATA / "designs" / f"{name}.json").read_text())
    return law_named(rec["controller"]).gains(rec["gains"]), InnerLoopGains(**rec["inner_loop"]), rec


def cascade_summary(cert):
    cas = cert.cascade
    return (f"yes: box {'= the Monte Carlo box' if cas['covers_monte_carlo_default'] else 'smaller than the Monte Carlo box'}, "
            f"decay {cas['decay_rate_1_s']:.3g} 1/s, reach {100 * cas['region_of_attraction']['max_displacement_m']:.3g} cm")


rows6 = []
for label, name in (("filtered PD, no class", "pd_filtered"), ("filtered PD, paper class", "pd_filtered_paper"),
                    ("filtered PD, cascade class", "pd_filtered_cascade")):
    pd_g, pd_inner, rec = design_record(name)
    rows6.append({"label": label, "nni": nni_from_filtered_pd(pd_g, V.m), "inner": pd_inner, "p95": rec["settling_s"],
                  "pd": pd_g, "cert": IMAGE_CERT if name == "pd_filtered" else None})
# written by `nniquad certify --law-class cascade --no-margins ...` (make_data.py, step nni_cascade_no_margins)
NO_MARGINS_CERT = notebook_certificate("designs", "nni_cascade_no_margins_certificate.json", vehicle=V)
# written by `nniquad certify --law-class cascade --warm-start designs/pd_filtered.json ...` (step nni_cascade_seeded)
SEEDED_CERT = notebook_certificate("designs", "nni_cascade_seeded_certificate.json", vehicle=V)
for label, cert in (("NNI, paper class (certified, seeded)", PAPER_CERT),
                    ("NNI, cascade class (certified)", CASCADE_CERT),
                    ("NNI, cascade class, no GM requirement (certified)", NO_MARGINS_CERT),
                    ("NNI, cascade class, seeded with the PD's image (certified)", SEEDED_CERT)):
    rows6.append({"label": label, "nni": cert.gains, "inner": cert.inner_loop, "p95": (cert.tuning or {}).get("settling_s"),
                  "pd": None, "cert": cert})
for r in rows6:
    g = r["nni"]
    r["gamma"] = ReducedLoop.from_vehicle(V, g).smallest_gamma
    r["sector"] = r["gamma"] <= GAMMA_MAX * (1 + 1e-12)
    r["box"] = g.kp <= LIM["kp_max"] * (1 + 1e-12) and g.Gamma * g.delta <= GD_MAX * (1 + 1e-12)
    ms = design_margins(V, g, r["inner"], tilt_limit_deg=TILT)
    r["gm"] = margin_shortfall(ms, include_pm=False) == 0.0
    r["pm"] = {k: m.pm_deg for k, m in ms.items()}
md_table(["design", "robust p95 [s]", "NNI image kp', Γ, δ", "γ (sector: ≤ 0.8)", "k_p τ_f/k_d",
          f"kp' ≤ {LIM['kp_max']:.0f}, Γδ ≤ {GD_MAX:.0f}", "GM ≥ 6 dB both ways", "PM horiz./att. [deg]",
          "sampled cascade certificate"],
         [[r["label"], fmt(r["p95"], ".3f"), f"{r['nni'].kp:.3g}, {r['nni'].Gamma:.3g}, {r['nni'].delta:.3g}",
           f"{r['gamma']:.3f} ({'holds' if r['sector'] else 'fails'})",
           "—" if r["pd"] is None else f"{r['pd'].kp * r['pd'].tau_f / r['pd'].kd:.3f}",
           f"{'yes' if r['box'] else 'no'} ({r['nni'].kp:.3g}, {r['nni'].Gamma * r['nni'].delta:.3g})",
           "yes" if r["gm"] else "no", f"{r['pm']['horizontal']:.1f} / {r['pm']['attitude']:.1f}",
           cascade_summary(r["cert"]) if r["cert"] is not None else "(its image seeds the class's NNI tuning)"]
          for r in rows6])
free, in_paper, in_cascade, nni_paper, nni_cascade, nni_no_margins, nni_seeded = rows6
# the committed certificate above (tuned without a seed) for comparison
committed_p95 = (CERT.tuning or {}).get("settling_s")
from nniquad.laws.search_ranges import CASCADE_GAMMA_CAP

# the best filtered PD whose NNI image lies in each class (the unrestricted PD is a candidate of every class its
# image lies in: the cascade class's coordinates cap gamma at CASCADE_GAMMA_CAP, both classes keep the search box)
pd_rows = (free, in_paper, in_cascade)
best_pd_in = {"paper": min((r for r in pd_rows if r["sector"] and r["box"]), key=lambda r: r["p95"]),
              "cascade": min((r for r in pd_rows if r["gamma"] <= CASCADE_GAMMA_CAP and r["box"]),
                             key=lambda r: r["p95"])}
cost_sector = best_pd_in["paper"]["p95"] - best_pd_in["cascade"]["p95"]
cost_rest = in_cascade["p95"] - free["p95"]
free_meets_all = free["box"] and free["gm"]
print(f"the sector bound costs the filtered PD {cost_sector:+.3f} s of robust p95 (best in the paper class "
      f"{best_pd_in['paper']['p95']:.3f} s against the cascade class {best_pd_in['cascade']['p95']:.3f} s)")
print(f"the tune restricted to the cascade class with the margins reached {in_cascade['p95']:.3f} s, "
      f"{cost_rest:+.3f} s from the unrestricted {free['p95']:.3f} s; "
      + ("the unrestricted design's image already lies in the box and meets the margins, so this is the optimiser's "
         "shortfall, not a constraint's" if free_meets_all else "its image leaves the box or misses the margins"))
print(f"certified NNI against the best filtered PD of its class: paper {nni_paper['p95']:.3f} s vs "
      f"{best_pd_in['paper']['p95']:.3f} s; cascade, seeded with that PD's image, {nni_seeded['p95']:.3f} s vs "
      f"{best_pd_in['cascade']['p95']:.3f} s (seeded with the held-ranked PD the speed study started from, which fails a corner as it flies: {nni_cascade['p95']:.3f} s) (the committed paper-class certificate, tuned "
      f"without a seed: {fmt(committed_p95, '.3f')} s); without the GM requirement (as the "
      f"unrestricted filtered PD is tuned) the cascade-class NNI reaches {nni_no_margins['p95']:.3f} s against the "
      f"filtered PD's {free['p95']:.3f} s")
# the speed study's filtered PD (1.93 s) was ranked on the continuous controller on the held measurement; as it flies
# (the discrete controller at 100 Hz, what every design above is ranked on) it is run here on the same 20 scenarios
from nniquad.config import FORMER_WIND_WEIGHT_FRACTION_RANGE
from nniquad.tuning.coordinates import encode
from nniquad.tuning.vehicle_limits import attitude_accel_headroom
from nniquad.tuning.objective import evaluate_details


def tuned_set(rec):
    """The wind range and measurement delay of the scenario set a 'tune --json' record was tuned on (a record that
    states none predates both: the former wind range, no delay)."""
    wind = rec.get("scenario_wind_fraction_range") or FORMER_WIND_WEIGHT_FRACTION_RANGE
    return tuple(wind), int(rec.get("scenario_delay_samples") or 0)


held_g, held_inner, held_rec = design_record("pd_filtered_held")
held_wind, held_delay = tuned_set(held_rec)  # its own scenario set, so its record's figure is comparable
held_opts = TuneOptions(model="full", controller="pd_filtered", require_margins=False, roa_radius_m=0.0,
                        scenario_wind_fraction_range=held_wind, delay_samples=held_delay)
held_q = encode(held_g, V.m, held_opts.gamma_max, held_inner, attitude_accel_headroom(V, TILT))[None]
held_eval = evaluate_details(V, held_q, held_opts, held_rec["metrics"]["horizon_s"], full_report=True)[0]
held_fail = [c for c in held_eval["scenario_costs"] if c is not None and c >= held_rec["metrics"]["horizon_s"]]
print(f"the speed study's filtered PD (robust p95 {held_rec['settling_s']:.3f} s ranked 'held'): as it flies, "
      + (f"robust p95 {held_eval['robust_settling_s']:.3f} s" if held_eval["robust_settling_s"] is not None
         else f"{len(held_fail)} of the {sum(c is not None for c in held_eval['scenario_costs'])} scenarios run fail "
            f"(the others are not run after a failed corner; cost {held_eval['cost']:.2f} s, the penalty)"))
# written by `nniquad certify --controller sni2 --law-class cascade --warm-start designs/pd_filtered.json ...`
# (make_data.py, step sni2_cascade_seeded)
SNI2_SEEDED_CERT = notebook_certificate("designs", "sni2_cascade_seeded_certificate.json", vehicle=V)
for label, sc in (("SNI2, cascade class (certified)", SNI2_CERT),
                  ("SNI2, cascade class, seeded with the PD's image (certified)", SNI2_SEEDED_CERT)):
    sni2_ms = design_margins(V, sc.gains, sc.inner_loop, tilt_limit_deg=TILT)
    print(f"{label}: robust p95 {sc.tuning['settling_s']:.3f} s, DC loop gain "
          f"γ = {sc.gains.dc_loop_gain(V.m):.3f}, ω = {sc.gains.omega:.4g} rad/s, ζ = {sc.gains.zeta:.3g}, "
          f"GM ≥ 6 dB both ways: {'yes' if margin_shortfall(sni2_ms, include_pm=False) == 0.0 else 'no'}, "
          f"cascade certificate: {cascade_summary(sc)}")

# %% [markdown]
# **What the position noise costs.**  Every design above is tuned on the robust
# set whose corners carry position noise σ = 2 cm at 100 Hz (the Monte Carlo
# range's upper end).  The PD law with true velocity meets that noise only
# through k_p; a velocity-free law differentiates it: the filtered PD's NNI
# image passes it to the command with its high-frequency gain
# k_p' = k_p + k_d/τ_f.  Both PD laws were tuned again on the same set with the
# noise removed and nothing else changed (`--scenario-noise-range 0 0`,
# make_data.py steps `pd_velocity_quiet` and `pd_filtered_quiet`), and each of
# the four designs is scored here on both sets.

# %%
from nniquad.tuning.objective import simulation_options

QUIET = (0.0, 0.0)
OUTPUT_DT_S = simulation_options(TuneOptions(model="full"), 1.0).output_dt_s  # the grid settling times are read on


def robust_p95s(designs, noise_range):
    """Each design's robust p95 on the tuning set with the given noise range (None: the default range), one batch
    per law; None where a scenario fails.  ``designs``: name -> :func:`design_record`."""
    out = {}
    for law, wind, delay in sorted({(rec["controller"], *tuned_set(rec)) for _, _, rec in designs.values()}):
        mine = [(n, d) for n, d in designs.items() if (d[2]["controller"], *tuned_set(d[2])) == (law, wind, delay)]
        opts = TuneOptions(model="full", controller=law, require_margins=False, scenario_noise_range_m=noise_range,
                           scenario_wind_fraction_range=wind, delay_samples=delay)
        alpha = attitude_accel_headroom(V, TILT)
        q = np.array([encode(g, V.m, opts.gamma_max, inner, alpha) for _, (g, inner, _) in mine])
        horizon = max(rec["horizon_s"] for _, (_, _, rec) in mine)
        for (n, _), d in zip(mine, evaluate_details(V, q, opts, horizon, full_report=True)):
            out[n] = d["robust_settling_s"]
    return out


NOISE_DESIGNS = {n: design_record(n) for n in ("pd_velocity", "pd_velocity_quiet", "pd_filtered", "pd_filtered_quiet")}
scored = {"default": robust_p95s(NOISE_DESIGNS, None), "quiet": robust_p95s(NOISE_DESIGNS, QUIET)}
noise_rows = {}
for name, (g, _, rec) in NOISE_DESIGNS.items():
    # files tuned before the option existed were tuned on the default range (their record does not state it)
    tuned_on = tuple(rec.get("scenario_noise_range_m") or TuneOptions(model="full").robust_noise_range_m)
    scores = {k: v[name] for k, v in scored.items()}
    own = scores["quiet" if tuned_on == QUIET else "default"]
    # the file's figure is reproduced on its own set (to one output sample: another machine's rounding may move a
    # band crossing by one sample, and the p95 interpolates between two scenarios' settling times)
    assert own is not None and abs(own - rec["settling_s"]) <= OUTPUT_DT_S, (name, own, rec["settling_s"])
    noise_rows[name] = {"tuned_on": tuned_on, **scores,
                        "kp_hf": g.kp + (g.kd / g.tau_f if isinstance(g, PDFilteredGains) else 0.0)}
show_p95 = lambda v: "fails a scenario" if v is None else f"{v:.3f}"  # noqa: E731
md_table(["design", "tuned on noise σ [cm]", "p95, default set [s]", "p95, no noise [s]",
          "gain from position noise to command [1/s²]"],
         [[n, f"{100 * r['tuned_on'][0]:g} to {100 * r['tuned_on'][1]:g}", show_p95(r["default"]), show_p95(r["quiet"]),
           f"{r['kp_hf']:.3g}"] for n, r in noise_rows.items()])
# written by `nniquad certify --law-class cascade --scenario-noise-range 0 0 --gains-from
# designs/pd_filtered_quiet.json` (make_data.py, step pd_image_quiet)
QUIET_IMAGE_CERT = notebook_certificate("designs", "pd_filtered_quiet_image_certificate.json", vehicle=V)
quiet_gap = noise_rows["pd_filtered_quiet"]["quiet"] / noise_rows["pd_velocity_quiet"]["quiet"] - 1.0
noisy_gap = noise_rows["pd_filtered"]["default"] / noise_rows["pd_velocity"]["default"] - 1.0
print(f"without noise the filtered PD is {100 * quiet_gap:+.1f} % from the PD with true velocity "
      f"({noise_rows['pd_filtered_quiet']['quiet']:.3f} s against {noise_rows['pd_velocity_quiet']['quiet']:.3f} s); "
      f"with the default noise {100 * noisy_gap:+.1f} % ({noise_rows['pd_filtered']['default']:.3f} s against "
      f"{noise_rows['pd_velocity']['default']:.3f} s)")
quiet_gamma = ReducedLoop.from_vehicle(V, QUIET_IMAGE_CERT.gains).smallest_gamma
print(f"the quiet filtered PD's NNI image, certified in the cascade class: robust p95 on the noise-free set "
      f"{QUIET_IMAGE_CERT.tuning['settling_s']:.3f} s, γ = {quiet_gamma:.3f}; "
      f"cascade certificate: {cascade_summary(QUIET_IMAGE_CERT)}")

# %% [markdown]
# **Which certificate needs which constraint.**  The sector bound is the
# hypothesis of the paper's Theorem `thm:main_result` as the project applies it
# (γ_max = 0.8): the `paper` class keeps it, the `cascade` class, whose proof is
# the sampled-data cascade certificate, does not.  Under the map every filtered
# PD has γ = k_d/(k_p τ_f + k_d) < 1, so the theorem's own hypothesis (some γ
# in (0, 1)) adds nothing to stability of the reduced loop; γ_max = 0.8 is a
# margin.  No certificate needs the search box or the gain margins: the box
# keeps the search on what the vehicle can realise and the margins are the
# flight-control requirement; the cascade certificate checks the sampled
# cascade directly over its parameter box.

# %%
needs = [["sector bound δ ≥ 1/(γ_max m̂ k_p')", " and ".join(f"{n}: {'needed' if c.sector_bound else 'not needed'}"
                                                            for n, c in LAW_CLASSES.items()),
          "Theorem thm:main_result (paper class)"],
         ["search box (k_p' ≤ k_p,max, Γδ ≤ π f_s)", "no certificate needs it", "what the vehicle and the sampling realise"],
         ["GM ≥ 6 dB both ways", "no certificate needs it", "flight-control practice (MIL-F-9490D)"],
         ["sampled-data cascade certificate", "paper: adds the parameter box; cascade: the whole proof",
          LAW_CLASSES["cascade"].theorem.split(":")[0]]]
md_table(["constraint", "needed by", "why it is there"], needs)

# %%
certified_p95 = {r["label"]: r["p95"] for r in (nni_paper, nni_cascade, nni_seeded)}
certified_p95["SNI2, cascade class (certified)"] = SNI2_CERT.tuning["settling_s"]
certified_p95["SNI2, cascade class, seeded with the PD's image (certified)"] = SNI2_SEEDED_CERT.tuning["settling_s"]
fastest_certified = min(certified_p95.items(), key=lambda kv: kv[1])
md_table(["certified velocity-free design", "robust p95 [s]"], [[k, f"{v:.3f}"] for k, v in certified_p95.items()])

# %%
# conclusion -- every number below was computed in this notebook
elapsed = time.perf_counter() - T_START
print("Conclusion")
print(f"- Design: kp = {GAINS.kp:.3g}, Γ = {GAINS.Gamma:.3g}, δ = {GAINS.delta:.3g} (γ = {gamma_used:.3f}, certified reach "
      f"{reach:.2f} m), ω_a = {wa0:.0f} rad/s; nominal full-model settling {nom.settling_s:.2f} s. "
      + f"Its attitude loop sits at the tuner's cap ζ_a/(2τ) = {wa_cap:.0f} rad/s "
      f"({'at' if abs(wa0 - wa_cap) < 1e-6 * wa_cap else 'below'} it), so 2ζ_a/(ω_a τ) = {ref_margin:.1f}.")
print(f"- Mass: works from {m_first_ok:.2f} to {m_last_ok:.2f} kg, fails at {m_break:.2f} kg. " + mass_why)
print(f"- Attitude bandwidth: fine from {wa_slowest:g} rad/s (slow: {wa_met[wa_slowest].settling_s:.1f} s) up to "
      f"{wa_ok_hi:.0f} rad/s, broken from {wa_bad_hi:.0f} rad/s; the hover Routh limit ω_a < 2ζ_a/τ = {wa_crit:.0f} rad/s "
      f"explains it, and the design sits at {100 * wa0 / wa_crit:.0f} % of that limit.")
print(f"- Motor lag: works up to {1000 * tau_ok_hi:g} ms, fails from {1000 * tau_bad:g} ms (limit 2ζ_a/ω_a = "
      f"{1000 * tau_crit:.1f} ms, nominal {1000 * tau0:g} ms): the margin is {100 * (tau_crit / tau0 - 1):.0f} %"
      + (f", and the run at {1000 * tau_bad:g} ms fails although its linearised margin is still "
         f"{attitude_margin(wa0, za0, tau_bad):.2f} > 1 (saturation and the ω² thrust law eat the rest). "
         if attitude_margin(wa0, za0, tau_bad) > 1 else ". ")
      + f"Without lag the same gains settle in {nl.settling_s:.2f} s, with the nominal lag in {nom.settling_s:.2f} s.")
print(f"- Wind: offset {compliance:.3f} m/N, {compliance / compliance_p:.1f} × that of the kp loop alone (the NNI positive "
      f"feedback costs stiffness, 1/(1 − γ)); held up to {F_ok:g} N, lost at {F_bad:g} N, against F_max = m a_max = "
      f"{F_max:.2f} N set by the {TILT:g}° tilt limit.")
m_lo = min(mass_met, key=lambda mm: abs(mm - 0.9 * V.m))
m_hi = min(mass_met, key=lambda mm: abs(mm - 1.1 * V.m))
wa_lo = max(w for w in WA if w < wa0)
tau_lo = max(t for t in TAUS if t < tau0)
robust_typ = float(np.median([m.settling_s for m in mass_met.values() if m.settling_s is not None]))


def rel(x):
    return f"{100 * (x / nom.settling_s - 1):+.0f} %"


print(f"- Off the design point: {nom.settling_s:.2f} s at the design point, {mass_met[m_lo].settling_s:.2f} s "
      f"({rel(mass_met[m_lo].settling_s)}) at {m_lo:.2f} kg and {mass_met[m_hi].settling_s:.2f} s "
      f"({rel(mass_met[m_hi].settling_s)}) at {m_hi:.2f} kg, {wa_met[wa_lo].settling_s:.2f} s "
      f"({rel(wa_met[wa_lo].settling_s)}) at ω_a = {wa_lo:g} rad/s and {tau_met[tau_lo].settling_s:.2f} s "
      f"({rel(tau_met[tau_lo].settling_s)}) at τ = {1000 * tau_lo:g} ms. About {robust_typ:.1f} s "
      f"(median over the working masses) is what the gains deliver robustly.")


def win_levels(rows):
    out = {}
    for row in rows:  # [level, law, ...]: the levels each law is fastest at
        out.setdefault(row[1], []).append(row[0])
    return "; ".join(f"{law} at {', '.join(levels)} %" for law, levels in out.items())


print(f"- {len(LAWS)} laws on the same scenarios (section 5): fastest front member at each success level: "
      + win_levels(winner_rows) + "; without a velocity sensor: " + win_levels(winner_rows_vf) + ". Most robust: "
      + "; ".join(f"{LAW_LABEL[law]} {100 * r['success']:.0f} % at {r['nominal_s']:.2f} s" for law, r in overall.items())
      + ". Largest speed-up λ at which every scenario still settles: "
      + "; ".join(f"{LAW_LABEL[law]} {max((r['lam'] for r in family if r['law'] == law and r['success'] == 1.0), default=0):g}"
                  for law in LAWS) + ".")
print(f"- Sections 5 and 6: the filtered PD is the NNI law (k_p' = k_p + k_d/τ_f, Γ = m̂ k_d/τ_f², δ = τ_f/(m̂ k_d)). "
      f"The tuned filtered PD's image has γ = {free['gamma']:.3f} "
      f"({'inside' if free['sector'] else 'outside'} the sector bound γ_max = {GAMMA_MAX:g}), "
      f"{'satisfies' if free['box'] else 'leaves'} the search box, {'meets' if free['gm'] else 'misses'} GM ≥ 6 dB, "
      f"and the sampled cascade certificate {'certifies' if IMAGE_CERT.cascade['covers_monte_carlo_default'] else 'certifies a smaller box than'} "
      f"the Monte Carlo box for it, but its region of attraction reaches "
      f"{100 * IMAGE_CERT.cascade['region_of_attraction']['max_displacement_m']:.0f} cm, not the paper's start. "
      f"The sector bound costs the filtered PD {cost_sector:+.2f} s of robust p95; "
      + ("the search box and the margins cost it nothing (its image meets both; the class-restricted tune's "
         f"{cost_rest:+.2f} s is the optimiser's). " if free_meets_all else
         f"the search box and the margins {cost_rest:+.2f} s. ")
      + f"Certified NNI: paper class {nni_paper['p95']:.2f} s (best filtered PD in the class "
      f"{best_pd_in['paper']['p95']:.2f} s), cascade class {nni_seeded['p95']:.2f} s seeded with the PD's image "
      f"(best filtered PD in the class {best_pd_in['cascade']['p95']:.2f} s). "
      f"Fastest certified velocity-free design: {fastest_certified[0]}, {fastest_certified[1]:.3f} s robust p95. "
      f"Position noise: without it the filtered PD is {100 * quiet_gap:+.1f} % from the PD with true velocity, "
      f"with the default 2 cm in the corners {100 * noisy_gap:+.1f} %: "
      + ("most of what the velocity sensor buys is immunity to the noise that a velocity-free law differentiates."
         if abs(quiet_gap) < 0.5 * noisy_gap else "the noise is not the larger part of what the velocity sensor buys."))
print(f"(notebook ran in {elapsed:.0f} s)")
