"""Closed-loop simulation: one entry point, :func:`simulate`, returning a :class:`SimulationResult`.

Modules
-------
:mod:`~nniquad.sim.options`
    :class:`SimOptions` (horizon, step, noise, wind, motor lag, ...).
:mod:`~nniquad.sim.params`
    The parameter vector of the compiled functions, its layout generated from
    the typed blocks (:func:`param_layout`, :class:`SimParams`).
:mod:`~nniquad.sim.models`
    CasADi closed-loop expressions of the ``linear``, ``reduced`` and ``full`` models.
:mod:`~nniquad.sim.codegen`
    C code generation and the compiled-function disk cache.
:mod:`~nniquad.sim.runner`
    :func:`simulate` and the batched runner.
:mod:`~nniquad.sim.step_check`
    The RK4 step check every run meets (:func:`~nniquad.sim.step_check.check_step`).
:mod:`~nniquad.sim.results`
    :class:`SimulationResult` (many runs, named signals, metrics, plot) and
    :class:`Trajectory` (one run).
"""

from nniquad.sim.codegen import cache_dir, compile_status
from nniquad.sim.models import output_function, rhs_function, step_function, vehicle_dynamics
from nniquad.sim.options import CONTROLLER_SAMPLING, MODELS, SimOptions, check_delay_samples, check_rate_hz
from nniquad.sim.params import (
    EXO_FIELDS,
    OUTPUT_NAMES,
    STATE_NAMES,
    ParamField,
    RunSettings,
    SimParams,
    VehicleParams,
    n_params,
    param_layout,
    delay_state_names,
    state_names,
    to_gains,
)
from nniquad.sim.results import SimulationResult, Trajectory
from nniquad.sim.runner import (
    PAPER_FIGURE_HORIZON_S,
    exogenous_inputs,
    initial_state,
    paper_figure_runs,
    run_batch,
    simulate,
)

__all__ = [
    "simulate",
    "SimulationResult",
    "Trajectory",
    "SimOptions",
    "SimParams",
    "VehicleParams",
    "RunSettings",
    "ParamField",
    "param_layout",
    "n_params",
    "to_gains",
    "MODELS",
    "CONTROLLER_SAMPLING",
    "check_rate_hz",
    "check_delay_samples",
    "STATE_NAMES",
    "state_names",
    "delay_state_names",
    "OUTPUT_NAMES",
    "EXO_FIELDS",
    "paper_figure_runs",
    "PAPER_FIGURE_HORIZON_S",
    "run_batch",
    "exogenous_inputs",
    "initial_state",
    "rhs_function",
    "output_function",
    "step_function",
    "vehicle_dynamics",
    "cache_dir",
    "compile_status",
]
