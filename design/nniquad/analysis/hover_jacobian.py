"""Jacobians of the simulator's closed loop at hover: the raw material of the linearised cascade.

The closed-loop right-hand side :func:`nniquad.sim.rhs_function` and the
horizontal-command output are differentiated with CasADi (the function is kept
in the code cache, :mod:`nniquad.codecache`) at the hover equilibrium, with the
simulator's ``sample_hold`` switch on, so that the Jacobian with respect to the
held states is the measurement input.  At exact hover the tilt limit's norm has
a ``0 · NaN`` derivative, so the Jacobian is the mean of the Jacobians at
``±ε`` along the held measurement (the odd terms cancel; error ``O(ε²)``).
:mod:`nniquad.analysis.linearised_cascade` splits these Jacobians into plant and
controller; :mod:`nniquad.analysis.cascade.family` evaluates them over a
parameter grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from nniquad.codecache import cached_casadi_function
from nniquad.errors import CascadeError
from nniquad.laws.registry import ni_law_names
from nniquad.sim import (
    EXO_FIELDS,
    OUTPUT_NAMES,
    SimParams,
    initial_state,
    n_params,
    output_function,
    rhs_function,
    state_names,
)

__all__ = ["LINEARISATION_OFFSET_M", "EQUILIBRIUM_TOL", "Linearisation", "linearise"]

#: Offset [m] of the held measurement for the symmetric-mean Jacobian (module docstring).
LINEARISATION_OFFSET_M = 1e-6
#: Largest ``|f(x_hover)|`` accepted as an equilibrium (absolute, in the state's units per second).
EQUILIBRIUM_TOL = 1e-9


@dataclass(frozen=True)
class Linearisation:
    """Jacobians of one simulator model at its hover equilibrium (``sample_hold`` on).

    Attributes
    ----------
    model
        Simulator model (``"linear"`` or ``"full"``).
    state_names
        Names of the simulator states (:func:`nniquad.sim.state_names`).
    x_eq : ndarray
        The hover state (position 0, at rest, rotors at the nominal hover speed).
    residual
        ``max |f(x_eq)|``: zero at an equilibrium.
    J : ndarray (n, n)
        ``∂f/∂x`` at ``x_eq``.
    Y : ndarray (2, n)
        ``∂a_h/∂x`` of the simulator output ``a_x, a_y`` (after the tilt limit).
    params
        The parameter vector used.
    """

    model: str
    state_names: tuple[str, ...]
    x_eq: np.ndarray
    residual: float
    J: np.ndarray
    Y: np.ndarray
    params: SimParams

    def index(self, *names: str) -> list[int]:
        """Positions of the named states."""
        return [self.state_names.index(n) for n in names]


@cached_casadi_function
def jacobian_function(model: str, controller: str = "nni") -> ca.Function:
    n = len(state_names(model, controller))
    X = ca.SX.sym("x", n)
    p = ca.SX.sym("p", n_params(controller))
    e = ca.DM.zeros(len(EXO_FIELDS))
    f = rhs_function(model, controller)(X, e, p)
    out = OUTPUT_NAMES[model]
    y = output_function(model, controller)(X, e, p)[[out.index("a_x"), out.index("a_y")]]
    return ca.Function(f"cascade_jac_{model}_{controller}", [X, p], [f, ca.jacobian(f, X), ca.jacobian(y, X)])


def linearise(model: str, params: SimParams, *, offset: float = LINEARISATION_OFFSET_M) -> Linearisation:
    """Jacobians of the simulator's closed loop at hover (``sample_hold`` forced on).

    Parameters
    ----------
    model
        ``"linear"`` or ``"full"`` (``"reduced"`` equals ``"linear"`` near hover).
    params
        Parameter set (:class:`nniquad.sim.SimParams`, gains of a law of the NI structure:
        :attr:`nniquad.laws.base.ControlLaw.ni_structure`, or of its integral variant); its ``run.sample_hold`` is set to 1 and
        ``run.discrete`` to 0 here.
    offset
        Symmetric offset of the held measurement [m] (module docstring).

    Returns
    -------
    Linearisation

    Raises
    ------
    CascadeError
        If hover is not an equilibrium of the model with these parameters, or
        a Jacobian is not finite.
    """
    if model not in ("linear", "full"):
        raise CascadeError(f"the cascade is linearised on the 'linear' or 'full' model, not {model!r}")
    if not isinstance(params, SimParams) or not (params.gains.law.ni_structure or params.gains.law.integral):
        raise CascadeError("the cascade is linearised with a SimParams of a law of the NI structure "
                           f"({', '.join(ni_law_names())}) or of its integral variant")
    p = params.with_(run={"sample_hold": 1.0, "discrete": 0.0})  # the continuous controller's Jacobian
    names = state_names(model, params.controller)
    x_eq = initial_state(model, p, (0.0, 0.0))
    fn = jacobian_function(model, params.controller)
    f0 = np.asarray(fn(x_eq, p.vector())[0], float).ravel()
    residual = float(np.max(np.abs(f0)))
    if not residual <= EQUILIBRIUM_TOL:
        raise CascadeError(f"hover is not an equilibrium of the {model} model (|f| = {residual:.3g}); "
                           "is the true mass different from the nominal one?")
    d = np.zeros(len(names))
    d[names.index("held_x")] = offset
    Js, Ys = [], []
    for sign in (1.0, -1.0):
        _, J, Y = fn(x_eq + sign * d, p.vector())
        Js.append(np.asarray(J, float))
        Ys.append(np.asarray(Y, float))
    J, Y = 0.5 * (Js[0] + Js[1]), 0.5 * (Ys[0] + Ys[1])
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(Y))):
        raise CascadeError(f"the Jacobian of the {model} model at hover is not finite")
    return Linearisation(model, names, x_eq, residual, J, Y, p)
