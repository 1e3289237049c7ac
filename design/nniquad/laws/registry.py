"""The registry of control laws: names to laws, and the gain block of any law from plain data.

Each law module calls :func:`register` once, at import; :mod:`nniquad.laws`
imports every law module, so the registry is full whenever any part of the
package is imported.  The command line's ``--controller`` choices, the
simulator's laws, the tuner's and the certificate's all come from here.
"""

from __future__ import annotations

import inspect
from typing import Any

from nniquad import codecache
from nniquad.errors import GainError, NniquadError
from nniquad.laws.base import ControlLaw, GainBlock

__all__ = ["LAWS", "register", "law_named", "law_of", "law_names", "ni_law_names", "to_gains", "DEFAULT_LAW"]

#: Every registered law, by name, in registration order.
LAWS: dict[str, ControlLaw] = {}

#: The law of a gain set given as plain numbers (a mapping or tuple without a law): the paper's.
DEFAULT_LAW = "nni"


def register(law: ControlLaw) -> ControlLaw:
    """Add a law to the registry (its name must be new) and tie its gains type to it; returns the law.

    Parameters
    ----------
    law
        An instance of a :class:`~nniquad.laws.base.ControlLaw` subclass.

    Raises
    ------
    ValueError
        A name already taken, a gains type that is not a :class:`~nniquad.laws.base.GainBlock` naming the law, or
        a controller state whose name does not begin with ``zc``.
    """
    if law.name in LAWS and LAWS[law.name] is not law:
        raise ValueError(f"a law named {law.name!r} is registered already")
    gt = law.gains_type
    if not (isinstance(gt, type) and issubclass(gt, GainBlock) and getattr(gt, "controller", None) == law.name):
        raise ValueError(f"the gains type of the {law.name!r} law must be a GainBlock whose controller is "
                         f"{law.name!r}")
    if not all(n.startswith("zc") for n in law.sim_state_names):
        raise ValueError(f"the {law.name!r} law's controller states must be named zc... (the cascade analysis finds "
                         f"them by it), got {law.sim_state_names}")
    LAWS[law.name] = law
    gt._registered_law = law
    # a law from outside the package generates simulator code: its source keys the code cache
    codecache.add_source(inspect.getfile(type(law)))
    return law


def unregister(name: str) -> None:
    """Remove a law from the registry (tests that register a toy law clean up with it).

    Parameters
    ----------
    name
        The law's name.
    """
    law = LAWS.pop(name, None)
    if law is not None:
        law.gains_type._registered_law = None


def law_named(name: Any, *, error: type[NniquadError] = GainError) -> ControlLaw:
    """The law registered as ``name``, else ``error`` naming the known laws (one line).

    Parameters
    ----------
    name
        A law's name (``"nni"``, ``"sni2"``, ...).
    error
        The exception class raised.
    """
    if isinstance(name, str) and name in LAWS:
        return LAWS[name]
    raise error(f"unknown controller {name!r} (choose one of {', '.join(LAWS)})")


def law_of(gains: Any) -> ControlLaw:
    """The law of a gain block.

    Parameters
    ----------
    gains
        A gain block of a registered law.

    Raises
    ------
    GainError
        Not a gain block of a registered law.
    """
    if isinstance(gains, GainBlock):
        return gains.law
    raise GainError(f"not a gain block of a registered law: {type(gains).__name__}")


def law_names() -> tuple[str, ...]:
    """The registered laws' names, in registration order."""
    return tuple(LAWS)


def ni_law_names() -> tuple[str, ...]:
    """The names of the laws of the NI structure (the paper's theorem applies to them)."""
    return tuple(n for n, law in LAWS.items() if law.ni_structure)


def to_gains(gains: Any, controller: str | None = None, *, error: type[NniquadError] = GainError) -> GainBlock:
    """A typed gain block from a block, a mapping or a tuple.

    Parameters
    ----------
    gains
        A gain block (returned as it is), or a mapping / tuple of the fields of ``controller``'s block.
    controller
        The law the gains must be for; ``None`` accepts any block and reads a mapping or a tuple as gains of
        :data:`DEFAULT_LAW`.
    error
        The exception class of an unknown law.

    Raises
    ------
    GainError
        Missing, unknown, non-finite or non-positive gains, or a block of another law.
    """
    if controller is None and isinstance(gains, GainBlock):
        return gains
    return law_named(DEFAULT_LAW if controller is None else controller, error=error).gains(gains)
