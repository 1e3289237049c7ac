"""The RK4 step check of the batched runner: every pole of a run must lie inside the step's stability region.

:func:`nniquad.sim.simulate` calls :func:`check_step` on every parameter set
before any work, so the Python API refuses a loop faster than its step in the
same words as the command line.  The commands call it too, earlier (before
their other checks and estimates), with ``hint`` naming their own options; a
Monte Carlo study checks the fastest plant its ranges can draw
(:func:`nniquad.study.check_study_step`).

The poles of a run (:func:`run_poles`): the controller's fastest pole
(:meth:`nniquad.laws.base.ControlLaw.fastest_pole`; NNI: ``-Γδ``, PD with a filtered
derivative: ``-1/τ_f``, ``sni2``: the faster pole of ``C(s)``), the motor pole ``-1/τ_m``
when motor lag is on, and on the ``full`` model the inner loops near hover
(:func:`nniquad.validate.inner_loop_poles`: attitude, yaw, altitude).  The
limit, ``|λ| dt <= RK4_STEP_LIMIT``, is :func:`nniquad.validate.check_rk4_step`.
"""

from __future__ import annotations

from typing import Mapping, Sequence

from nniquad.errors import NniquadError, SimulationError
from nniquad.laws.registry import LAWS
from nniquad.sim.params import SimParams
from nniquad.validate import check_rk4_step, inner_loop_poles

__all__ = ["run_poles", "check_step", "API_HINTS", "law_hints"]

#: What to change, by pole, in the terms of the Python API (the commands pass their option names); each law's
#: controller pole is named and hinted by the law (:attr:`nniquad.laws.base.ControlLaw.pole_label`).
API_HINTS: dict[str, str] = {
    "attitude": "InnerLoopGains attitude_wn_rad_s, attitude_zeta or attitude_gain_scale, or SimOptions.dt_s",
    "yaw": "InnerLoopGains yaw_wn_rad_s or yaw_zeta, or SimOptions.dt_s",
    "altitude": "InnerLoopGains altitude_wn_rad_s, or SimOptions.dt_s",
    "motor lag": "the motor time constant (SimOptions.tau_motor_s, plant tau_motor) or SimOptions.dt_s",
}


def run_poles(params: SimParams, model: str) -> dict[str, float]:
    """Magnitudes ``|λ|`` [1/s] of the poles RK4 must resolve in one run.

    Parameters
    ----------
    params
        The run's parameter set.
    model
        ``"linear"``, ``"reduced"`` or ``"full"`` (the inner loops are simulated on ``full`` only).

    Returns
    -------
    dict
        Pole name -> ``|λ|``; the names are the keys of :data:`API_HINTS`.
    """
    g = params.gains
    poles: dict[str, float] = {}
    fastest = g.law.fastest_pole(g, float(params.nominal.m))
    if fastest is not None:
        poles[g.law.pole_label] = float(fastest)
    lag = params.run.motor_lag > 0.5
    if model == "full":
        poles.update(inner_loop_poles(params.inner, tau_motor_s=float(params.plant.tau_motor) if lag else None))
    elif lag:
        poles["motor lag"] = 1.0 / float(params.plant.tau_motor)
    return poles


def check_step(params: SimParams | Sequence[SimParams], model: str, *, hint: Mapping[str, str] | None = None,
               error: type[NniquadError] = SimulationError) -> None:
    """Refuse a run whose RK4 step ``run.dt`` is too large for one of its poles.

    Parameters
    ----------
    params
        One parameter set or several (each is checked at its own step).
    model
        The model simulated.
    hint
        What to change, by pole name (default :data:`API_HINTS`).
    error
        The exception class raised (a :class:`~nniquad.errors.NniquadError`).

    Raises
    ------
    SimulationError
        (or ``error``) naming the pole, its ``|λ|``, the largest step it allows and what to change.
    """
    for p in [params] if isinstance(params, SimParams) else params:
        hints = {**law_hints(), **(API_HINTS if hint is None else hint)}
        check_rk4_step(run_poles(p, model), float(p.run.dt), error=error, hint=hints)


def law_hints() -> dict[str, str]:
    """What to change for each registered law's controller pole, by its label (the Python API's names)."""
    return {law.pole_label: law.pole_hint for law in LAWS.values()}
