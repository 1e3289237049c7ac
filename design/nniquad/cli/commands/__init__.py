"""Sub-commands of the ``nniquad`` CLI, one module each (see :mod:`nniquad.cli.main`)."""
