"""Sub-commands of the ``nniquad`` CLI, one module each (see :mod:`design.cli`)."""
