"""Every default of the project, in one place.

Modules, the command line, the report and the notebooks read these names;
none of them retypes the numbers.
"""

from __future__ import annotations

import math

__all__ = [
    "XI0_M",
    "XI0_NORM_M",
    "TILT_LIMIT_DEG",
    "BAND_FRACTION",
    "GAMMA_MAX",
    "DIVERGENCE_FACTOR",
    "ALTITUDE_LIMIT_M",
    "DT_S",
    "OUTPUT_DT_S",
    "MASS_RANGE_FRACTION",
    "CONTROL_RATE_HZ",
    "ROBUST_DELAY_SAMPLES",
    "TRACKING_ACCEL_LIMIT_M_S2",
    "TRACKING_JERK_LIMIT_M_S3",
    "EXPORT_POSITION_ERROR_LIMIT_M",
    "REQUIRED_GM_DB",
    "REQUIRED_PM_DEG",
    "TAU_MOTOR_FACTOR_RANGE",
    "WIND_WEIGHT_FRACTION_RANGE",
    "FORMER_WIND_WEIGHT_FRACTION_RANGE",
    "STEADY_OFFSET_WINDOW_S",
    "NOISE_BUDGET_SIGMA_M",
    "NOISE_BUDGET_TILT_RMS_DEG",
    "NOISE_BUDGET_ROTOR_LIMIT_SHARE",
    "ATTITUDE_GAIN_MARGIN",
    "CASCADE_BANDWIDTH_RATIO",
    "TUNING_SCENARIO_SEED",
    "SETTLING_HOLD_MIN_S",
    "SETTLING_HOLD_FACTOR",
    "MC_STALL_TIMEOUT_S",
    "MC_STARTUP_GRACE_S",
    "MC_WITHIN_RIM_FRACTION",
    "INPUT_MAX_BYTES",
    "INPUT_MAX_DEPTH",
    "INPUT_MAX_INT_DIGITS",
    "RK4_STEP_LIMIT",
    "MEMORY_FRACTION",
    "RUN_TIME_LIMIT_S",
    "CASCADE_GRID_POINTS_PER_AXIS",
    "CASCADE_GRID_MAX_POINTS_PER_AXIS",
    "CASCADE_ROA_DECAY_FRACTION",
    "CASCADE_LURE_LEVELS",
    "CASCADE_LURE_MARGIN",
    "CASCADE_LURE_CUT_ROUNDS",
    "CASCADE_LURE_CUT_POINTS",
    "CASCADE_WIDEST_SCALE_MAX",
    "CASCADE_WIDEST_STEPS",
    "CASCADE_SMALLEST_SCALE",
    "CASCADE_LYAPUNOV_RTOL",
    "CASCADE_REACH_DECAY_FRACTION",
]

#: Initial horizontal position of the paper's run, north/east [m], at rest (DESIGN.md).
XI0_M: tuple[float, float] = (2.0, -1.5)
#: Its distance from the origin [m]: the default certified reach and the scale of the settling band.
XI0_NORM_M: float = math.hypot(*XI0_M)
#: Tilt limit [deg]; the horizontal acceleration is then at most g tan(30 deg).
TILT_LIMIT_DEG: float = 30.0
#: Settling band as a fraction of the initial distance (2 %).
BAND_FRACTION: float = 0.02
#: gamma_max of the sector bound, the paper's choice.
GAMMA_MAX: float = 0.8
#: A run whose distance exceeds this multiple of its initial distance has diverged.
DIVERGENCE_FACTOR: float = 100.0
#: A ``full`` run whose altitude deviates by more than this [m] has lost altitude (a failure).
ALTITUDE_LIMIT_M: float = 2.0
#: RK4 step of every simulation [s].
DT_S: float = 1e-3
#: Output sample period of a simulation [s].
OUTPUT_DT_S: float = 0.01
#: Default true-mass interval of the robust LMIs and certificates, as fractions of the nominal mass.
MASS_RANGE_FRACTION: tuple[float, float] = (0.8, 1.2)
#: Default class of the certified tracking-error bound (nniquad.analysis.tracking_bound): references whose
#: acceleration norm stays below this [m/s²] (a figure-eight of 2 m x 1 m amplitudes and period 8 s peaks at
#: 2.6 m/s², a 1 m circle in 4 s at 2.5 m/s²) ...
TRACKING_ACCEL_LIMIT_M_S2: float = 3.0
#: ... and, with acceleration feedforward, whose jerk norm stays below this [m/s³] (the same figure-eight: 3.9).
TRACKING_JERK_LIMIT_M_S3: float = 5.0
#: Control rate = position sample rate [Hz] of the sampled-data loop and of the exported controller.
CONTROL_RATE_HZ: float = 100.0
#: Measurement delay [control periods] the robust default tuning scenarios and ``certify`` cover: the position
#: reaches the law this many samples late (motion capture and GNSS stacks: 10-30 ms; 2 samples = 20 ms at 100 Hz).
ROBUST_DELAY_SAMPLES: int = 2
#: The exported C step scales a larger position error down to this norm [m] (direction kept) before the law: a
#: glitch then cannot overflow the command or wind the controller state up for minutes.  Far beyond any certified
#: reach, so the law inside it is exactly the certified one.
EXPORT_POSITION_ERROR_LIMIT_M: float = 1000.0
#: Required gain margin [dB], both ways (gain increase and reduction); flight-control practice (MIL-F-9490D).
REQUIRED_GM_DB: float = 6.0
#: Required phase margin [deg]; flight-control practice (MIL-F-9490D).
REQUIRED_PM_DEG: float = 45.0

#: Monte Carlo range of the motor time constant as factors of the vehicle's nominal one.
#: The same factor (its upper end) bounds the attitude bandwidth the tuner may choose.
TAU_MOTOR_FACTOR_RANGE: tuple[float, float] = (0.5, 2.0)
#: Monte Carlo range of the constant wind force as a fraction of the nominal weight m g: 10 % is
#: the drag of a 6.5 m/s breeze on the paper's 0.5 kg vehicle (C_d A ~ 0.02 m^2; 6 % at 5 m/s), and
#: a sixth of the m g tan(30 deg) = 58 % of the weight the tilt limit can hold against.
WIND_WEIGHT_FRACTION_RANGE: tuple[float, float] = (0.0, 0.10)
#: The default wind range before it reached 10 % (issue 44).  A tuning record that states no wind range
#: (``scenario_wind_fraction_range``) was tuned on this one, and without a measurement delay.
FORMER_WIND_WEIGHT_FRACTION_RANGE: tuple[float, float] = (0.0, 0.06)
#: The steady offset of a run (nniquad.sim.metrics.steady_offset_m) is its mean distance from the setpoint
#: over this final window [s].
STEADY_OFFSET_WINDOW_S: float = 1.0
#: Noise budget in hover at NOISE_BUDGET_SIGMA_M position noise at the control rate: RMS commanded tilt [deg]
#: and share of integration steps with a rotor command at its limit (targets of issue 44).
NOISE_BUDGET_SIGMA_M: float = 0.02
NOISE_BUDGET_TILT_RMS_DEG: float = 2.0
NOISE_BUDGET_ROTOR_LIMIT_SHARE: float = 0.05
#: Gain margin (a factor on the motor time constant, 2 = 6 dB) the attitude loop keeps at the
#: slowest motor of TAU_MOTOR_FACTOR_RANGE (nniquad.control.inner_loops.attitude_wn_limit).
ATTITUDE_GAIN_MARGIN: float = 2.0
#: The tuner's search box keeps the horizontal loop's natural frequency sqrt(kp) this factor below the
#: fastest attitude natural frequency the vehicle's motors allow (the usual 3-5x time-scale separation of a
#: cascade, at its permissive end; nniquad.tuning.vehicle_limits.gain_limits).
CASCADE_BANDWIDTH_RATIO: float = 3.0
#: Seed of the robust tuner's fixed scenario set (nniquad.tuning.robust_scenarios). A benchmark Monte Carlo
#: study of a tuned design must use another seed, or it re-measures the scenarios it was tuned on.
TUNING_SCENARIO_SEED: int = 14014
#: A settling time s counts only if the run is shown to stay in the band for
#: max(SETTLING_HOLD_MIN_S, SETTLING_HOLD_FACTOR * s) after it (else: did not settle).
SETTLING_HOLD_MIN_S: float = 5.0
SETTLING_HOLD_FACTOR: float = 2.0
#: Largest input file (vehicle, certificate) read [bytes]; a certificate is about 30 kB.
INPUT_MAX_BYTES: int = 16 * 2**20
#: Deepest nesting of JSON/TOML arrays and tables accepted in an input file (a certificate nests 5 levels).
INPUT_MAX_DEPTH: int = 64
#: Longest integer literal accepted in an input file (Python's default int-to-str limit, whatever it is set to).
INPUT_MAX_INT_DIGITS: int = 4300
#: RK4 is stable for every pole lambda with ``|lambda dt| <= 2.61`` in the left half-plane (2.785 on the real
#: axis); every step-size check (controller pole Gamma*delta, inner loops, motor lag) demands ``|lambda| dt <=`` this.
RK4_STEP_LIMIT: float = 2.5
#: A request may use at most this fraction of the memory available when it starts.
MEMORY_FRACTION: float = 0.8
#: A request estimated to run longer than this is refused [s] (30 days).
RUN_TIME_LIMIT_S: float = 30 * 86400.0

#: A Monte Carlo study on a process pool or a Dask cluster stops (and saves what finished) when no
#: batch has finished for this long [s]; a default batch (50 scenarios of 20 s) takes a few seconds.
MC_STALL_TIMEOUT_S: float = 120.0
#: Until its first batch finishes, a study waits at least this long before calling the pool or cluster
#: stalled [s]: workers start, import nniquad and build the simulator (a few seconds each, more when loaded).
MC_STARTUP_GRACE_S: float = 60.0
#: Fraction of ``montecarlo --within-certificate`` starts drawn on the rim of the certified disk (the others
#: uniformly over it): the certified region is closed, and its boundary is where a false claim would show first.
MC_WITHIN_RIM_FRACTION: float = 0.1

#: Points per coordinate of the numpy grid check inside a cascade certificate's parameter box
#: (nniquad.analysis.cascade.box_certificate.grid_check; six coordinates, so 4 gives 4096 points).
CASCADE_GRID_POINTS_PER_AXIS: int = 4
#: The most points per coordinate a cascade grid may have (6**6 = 46,656 rebuilt 29-state loops, about 0.3 GB):
#: ``certify`` refuses more, and ``verify`` refuses a certificate that asks for more (an absurd resource request).
CASCADE_GRID_MAX_POINTS_PER_AXIS: int = 6
#: The cascade's saturated region of attraction (nniquad.analysis.cascade.region) is certified with a decrease
#: ``V(x+) - V(x) <= -(1 - rho^2) x'Px``, rho = exp(-fraction * the horizontal blocks' linear decay * T):
#: a strict decrease, so the trajectories converge. 0.1 left the LMI 5 times further from feasible between
#: its points than 0.01.
CASCADE_ROA_DECAY_FRACTION: float = 0.01
#: Levels ``c`` of the region {V <= c} tried on the centre point (the sector multiplier is 1); the best one and
#: its neighbours at half steps are then tried at every LMI point, best first. Paper's design: about 570-800
#: is best (3.4 m at the centre, 2.8-3.0 m over the box; 2.7 m at 500 and at 1000).
CASCADE_LURE_LEVELS: tuple[float, ...] = (25.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0, 3200.0, 6400.0)
#: Margin of the region LMI's decrease, ``F <= -margin (diag(P) + I)`` (the metric in which verify judges the
#: decrease: each state in the units of V, each dead-zone input in those of the limit), so that the grid points
#: between the LMI points pass too. Paper's design: 1e-4 reaches 2.82 m after one cutting-plane round of 24
#: points; 3e-4 2.76 m; 1e-3 2.17 m.
CASCADE_LURE_MARGIN: float = 1e-4
#: Cutting-plane rounds of the region LMI: the grid points where the numpy check fails join the LMI points.
#: Paper's design: one round of 24 points, then all 4096 grid points pass.
CASCADE_LURE_CUT_ROUNDS: int = 3
#: Failing grid points added per axis and round: the worst one, then each the farthest from those chosen
#: (:func:`nniquad.analysis.cascade.region_lmi._spread_worst`). The tests' small design: one round instead of two.
CASCADE_LURE_CUT_POINTS: int = 24
#: Largest scale (log space, about nominal) of the Monte Carlo default box the widest-box search tries.
CASCADE_WIDEST_SCALE_MAX: float = 2.0
#: Bisection steps of the widest-box search (``certify --widest-box``), after its halving steps.
CASCADE_WIDEST_STEPS: int = 4
#: When the Monte Carlo box does not certify, the box search halves its scale (log space about nominal)
#: down to this one before refusing the design.
CASCADE_SMALLEST_SCALE: float = 0.03
#: Relative accuracy of each cascade subsystem's decay rate (nniquad.analysis.sampled.best_decay): the
#: first target is 98 % of the spectral bound, and the solver's answer there usually beats it.
CASCADE_LYAPUNOV_RTOL: float = 0.02
#: The horizontal axes' Lyapunov matrices of a cascade certificate are re-solved for the widest
#: linear-zone reach at this fraction of their best decay rate (kept when they reach further and pass
#: the grid check). Paper's design, x axis: 0.9 gave 19.6 cm at 0.83 1/s, against 4.8 cm at 0.998 1/s.
CASCADE_REACH_DECAY_FRACTION: float = 0.9
