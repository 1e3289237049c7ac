"""Monte Carlo robustness studies of a certified gain set, on one machine or a Dask cluster.

A certificate says what the theory guarantees for the *nominal* vehicle.  This
package asks what happens to the ``full`` closed loop (:mod:`nniquad.sim`:
12-state vehicle, inner loops, rotor saturation) when the things the model
leaves out are drawn at random:

=====================  =========================================  ==========================
perturbation           default range (:class:`ScenarioRanges`)    where it enters
=====================  =========================================  ==========================
mass                   nominal × U[0.8, 1.2]                       true plant ``m``; the
                                                                   controller keeps ``m̂``
inertia                each axis × U[0.8, 1.2]                     true ``Jx, Jy, Jz``
                       (``Jz`` capped at ``Jx + Jy``)
attitude-loop gain     × U[0.7, 1.3]                               ``att_scale`` (torques)
motor time constant    nominal × U[0.5, 2], lag on                 ``tau_motor``
position noise σ       U[0, 2] cm, sampled and held at 100 Hz      exogenous input
                       (the law runs in discrete time at
                       that rate)
wind force             magnitude U[0, 10] % of m g,                ``wind_x, wind_y``
                       direction U[0°, 360°)
initial displacement   uniform over the disk of radius             ``xi0``, at rest
                       ``min(certified region, 5 m)``
=====================  =========================================  ==========================

Why these ranges: a battery swap or a camera changes a 0.5 kg vehicle's mass
by 10-20 %; inertias measured by a pendulum test or taken from CAD are good to
10-20 %; the attitude-loop gain error lumps the errors of the thrust and drag
coefficients and of the inertia estimate (±30 %); small brushless motors with
light propellers have time constants of 10-50 ms, but a given vehicle's motor is
known to about a factor of 2 either way (ESC firmware, battery sag, temperature,
propeller change), so the range is relative to the vehicle's nominal ``tau_motor``
(an absolute range, ``tau_motor_s``, may still be given; the old default 5-40 ms
was 8× the nominal of a 5 ms motor);
2 cm is the noise of RTK-GNSS or UWB positioning (motion capture is below
1 mm); 10 % of the weight (0.49 N on the paper vehicle) is the drag of a
6.5 m/s breeze on a drag area C_d A ≈ 0.02 m²
(:data:`nniquad.config.WIND_WEIGHT_FRACTION_RANGE`).

Within the certificate
----------------------
:func:`within_certificate_ranges` turns a certificate's ``cascade`` section
(schema 2) into ranges that stay inside what it certifies: its parameter box,
its region of attraction, its rate, no noise and no wind.  Every such scenario
must converge; ``nniquad montecarlo --within-certificate`` exits 1 on any
failure.

Success
-------
A scenario succeeds when it *settled* and never *diverged*:

* **settled** -- the horizontal position ends, and stays from its settling time
  on, inside the band of 2 % of the certificate's nominal initial distance
  ``‖xi0_m‖`` (0.05 m for (2, -1.5) m) around the **setpoint**,
  :func:`nniquad.sim.metrics.settling_time_batch` (last exit, interpolated).
  A law without integral action holds a constant wind force ``F`` at the
  static equilibrium ``ξ_eq = F / (m̂ k_p (1 − γ))`` per axis (NNI:
  ``F / (m̂ k_p − 1/δ)``; exact for the full model with its altitude
  integrator); beyond the band that run has not settled.  The settling about
  that equilibrium, the verdict of earlier versions, stays in each record as
  ``settling_time_about_wind_equilibrium_s`` and decides nothing; the
  equilibrium's distance is ``offset_m`` and the distance the run ends at,
  averaged over its last second, ``steady_offset_m``.

A vehicle is *lost* (diverged) when it blew up or lost its altitude, and the
failure names the cause:

* **diverged** -- it blew up: a non-finite position or altitude, or a
  horizontal distance beyond ``DIVERGENCE_FACTOR · max(‖ξ(0)‖, band)`` (100 ×);
* **altitude lost** -- an altitude deviation beyond ``altitude_limit_m``
  (default :data:`nniquad.config.ALTITUDE_LIMIT_M`, 2 m; a vehicle whose
  thrust cannot carry its mass falls and fails here).

Both verdicts are the project's one definition
(:mod:`nniquad.sim.verdicts`), the same that ``simulate`` and ``tune`` use.

Reproducibility
---------------
Scenario ``i`` of a study with seed ``S`` is drawn from its own stream,
``numpy.random.default_rng(SeedSequence(S, spawn_key=(i,)))`` -- the same
stream as ``SeedSequence(S).spawn(n)[i]`` -- so it does not depend on ``n``, on
the batch size or on the number of workers, and can be rerun alone
(``nniquad montecarlo --seed S --rerun i``).  Its noise sequence comes from an
integer seed drawn from that stream.  Results are sorted by index before
they are summarised.

Modules
-------
:mod:`~nniquad.scenarios.draws`
    ranges, the study setup, the seeded draw of each scenario;
:mod:`~nniquad.study.runs`
    one :func:`nniquad.sim.simulate` call per scenario and its verdict;
:mod:`~nniquad.study.executors`
    in-process, local process pool or Dask cluster;
:mod:`~nniquad.study.statistics`
    success rate, quantiles and their confidence intervals.
"""

from nniquad.errors import MonteCarloError, StudyFailedError
from nniquad.scenarios.draws import (
    BOX_KEYS,
    DEFAULT_HORIZON_S,
    DEFAULT_RANGES,
    Scenario,
    ScenarioRanges,
    StudySetup,
    certificate_rate_hz,
    draw_scenario,
    study_setup_from,
    within_certificate_ranges,
)
from nniquad.scenarios.setup import check_study_step
from nniquad.study.certificate_setup import draw_scenarios, study_setup
from nniquad.study.executors import (
    CONNECT_TIMEOUT_S,
    STOP_SIGNALS,
    StopRequest,
    StudyRun,
    auto_batch_size,
    catch_interrupts,
    close_client,
    cluster_threads,
    connect_scheduler,
    make_batches,
    run_study,
)
from nniquad.study.runs import ScenarioResult, run_scenarios
from nniquad.study.statistics import Summary, pareto_front, quantile_ci, summarize, wilson_interval

__all__ = [
    "MonteCarloError",
    "StudyFailedError",
    "ScenarioRanges",
    "DEFAULT_RANGES",
    "StudySetup",
    "Scenario",
    "ScenarioResult",
    "StudyRun",
    "Summary",
    "study_setup",
    "study_setup_from",
    "within_certificate_ranges",
    "certificate_rate_hz",
    "BOX_KEYS",
    "draw_scenario",
    "draw_scenarios",
    "check_study_step",
    "run_scenarios",
    "make_batches",
    "auto_batch_size",
    "run_study",
    "StopRequest",
    "STOP_SIGNALS",
    "catch_interrupts",
    "connect_scheduler",
    "close_client",
    "cluster_threads",
    "summarize",
    "wilson_interval",
    "quantile_ci",
    "pareto_front",
    "DEFAULT_HORIZON_S",
    "CONNECT_TIMEOUT_S",
]
