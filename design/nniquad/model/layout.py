"""Layout of the numeric vectors of the vehicle model: state order and parameter order.

Plain tuples, without sympy, so that code which only needs the layout (the
simulator's parameter tables, a cached generated function) does not import the
symbolic model.  :mod:`nniquad.model.symbolic` builds its state vector in
:data:`STATE_ORDER`; :mod:`nniquad.model.numeric` packs the vehicle into
:data:`PARAM_NAMES`.
"""

from __future__ import annotations

__all__ = ["STATE_ORDER", "PARAM_NAMES", "FRAMES", "DEFAULT_FRAME"]

#: The paper's state order x = [x, x', y, y', z, z', phi, phi', theta, theta', psi, psi'].
STATE_ORDER: tuple[str, ...] = (
    "x", "x_dot", "y", "y_dot", "z", "z_dot",
    "phi", "phi_dot", "theta", "theta_dot", "psi", "psi_dot",
)

#: The rotor layouts a vehicle may have (:func:`nniquad.model.symbolic.rotor_geometry` derives each).
FRAMES: tuple[str, ...] = ("+", "x")
#: The layout of a vehicle that states none (every vehicle file and certificate written before frames existed).
DEFAULT_FRAME = "+"

#: Names of the entries of the parameter vector ``p`` (vehicle attribute names).  ``frame_index`` is the
#: position of the vehicle's frame in :data:`FRAMES`: the generated code selects that frame's mixer with it,
#: so one compiled function serves both layouts and a '+' and an 'x' vehicle never share a mixer.
PARAM_NAMES: tuple[str, ...] = ("m", "g", "Jx", "Jy", "Jz", "Jr", "l", "b", "d", "frame_index")
