"""Layout of the numeric vectors of the vehicle model: state order and parameter order.

Plain tuples, without sympy, so that code which only needs the layout (the
simulator's parameter tables, a cached generated function) does not import the
symbolic model.  :mod:`nniquad.model.symbolic` builds its state vector in
:data:`STATE_ORDER`; :mod:`nniquad.model.numeric` packs the vehicle into
:data:`PARAM_NAMES`.
"""

from __future__ import annotations

__all__ = ["STATE_ORDER", "PARAM_NAMES"]

#: The paper's state order x = [x, x', y, y', z, z', phi, phi', theta, theta', psi, psi'].
STATE_ORDER: tuple[str, ...] = (
    "x", "x_dot", "y", "y_dot", "z", "z_dot",
    "phi", "phi_dot", "theta", "theta_dot", "psi", "psi_dot",
)

#: Names of the entries of the parameter vector ``p`` (vehicle field names).
PARAM_NAMES: tuple[str, ...] = ("m", "g", "Jx", "Jy", "Jz", "Jr", "l", "b", "d")
