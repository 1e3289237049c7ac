"""The ``nniquad`` command line (:mod:`nniquad.cli.main`); each sub-command in :mod:`nniquad.cli.commands`."""

from nniquad.cli.main import main

__all__ = ["main"]
