"""A Crazyflie out-of-tree controller that flies an exported certified law.

``nniquad export --format crazyflie`` writes the C export (:mod:`nniquad.certificates.c_export`)
and, beside it, ``<prefix>_crazyflie.c``: ``controllerOutOfTreeInit``,
``controllerOutOfTreeTest`` and ``controllerOutOfTree`` for the firmware's
out-of-tree controller hook.  The position loop (the exported step) runs at 100 Hz
inside the firmware's 1 kHz stabilizer tick (``RATE_DO_EXECUTE(RATE_100_HZ, tick)``);
the firmware's own altitude loop gives the thrust and its attitude PIDs track the
law's setpoints.  The template (package data, ``templates/crazyflie_out_of_tree.c``)
states the frame conversion: the firmware's world frame has z up, the export's is NED.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

from nniquad.certificates.certificate import Certificate
from nniquad.certificates.export import FORMATS, export_controller, export_prefix, export_rate_hz
from nniquad.control.inner_loops import TILT_COMPENSATION_MIN_COS
from nniquad.errors import ExportError
from nniquad.io import atomic_write_text

__all__ = ["EXPORT_FORMATS", "CRAZYFLIE_RATE_HZ", "crazyflie_source", "export_for"]

#: Every format ``nniquad export`` writes: the controller's own, and the Crazyflie example.
EXPORT_FORMATS: tuple[str, ...] = (*FORMATS, "crazyflie")
#: The firmware's position-loop rate (``POSITION_RATE``, ``RATE_100_HZ``) [Hz]: the example needs the export at it.
CRAZYFLIE_RATE_HZ = 100.0


def crazyflie_source(prefix: str) -> str:
    """The out-of-tree controller's C source for an export with ``prefix``.

    Parameters
    ----------
    prefix
        The export's C prefix.
    """
    template = resources.files("nniquad.integrations").joinpath("templates/crazyflie_out_of_tree.c").read_text()
    return (template.replace("@PREFIX@", prefix).replace("@UPPER@", prefix.upper())
            .replace("@TILT_MIN_COS@", repr(float(TILT_COMPENSATION_MIN_COS))))


def export_for(cert: "Certificate | Mapping[str, Any]", out_dir: str | os.PathLike[str], fmt: str = "json",
               rate_hz: float | None = None, prefix: str | None = None) -> list[Path]:
    """Write an export in any of :data:`EXPORT_FORMATS` (``crazyflie``: the C files and the example).

    Parameters
    ----------
    cert
        A certificate or its JSON mapping.
    out_dir
        Output folder.
    fmt
        One of :data:`EXPORT_FORMATS`.
    rate_hz
        Control rate [Hz] (:func:`nniquad.certificates.export.export_controller`); ``crazyflie`` needs
        :data:`CRAZYFLIE_RATE_HZ` (the default when the certificate certifies it).
    prefix
        C prefix (default :func:`nniquad.certificates.export.export_prefix`).

    Raises
    ------
    ExportError
        Unknown format, or a Crazyflie export at another rate than the firmware's position loop.
    """
    if fmt != "crazyflie":
        return export_controller(cert, out_dir, fmt, rate_hz, prefix)
    if export_rate_hz(cert, rate_hz) != CRAZYFLIE_RATE_HZ:
        raise ExportError(f"the Crazyflie runs its position loop at {CRAZYFLIE_RATE_HZ:g} Hz; export at that rate "
                          f"(--rate {CRAZYFLIE_RATE_HZ:g})")
    name = export_prefix(cert, prefix)
    written = export_controller(cert, out_dir, "c", rate_hz, prefix)
    return [*written, atomic_write_text(Path(out_dir) / f"{name}_crazyflie.c", crazyflie_source(name))]
