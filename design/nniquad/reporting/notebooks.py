"""The notebooks' parameters and data: which vehicle they study, where their committed designs are.

A notebook (``notebooks/*.py``) never reads the working folder: it takes its
vehicle from ``$NNIQUAD_VEHICLE`` (:func:`notebook_vehicle`) and its committed
designs from the ``notebooks/data`` folder of the source checkout the package
runs from, or from ``$NNIQUAD_NOTEBOOK_DATA`` (:func:`notebook_data`), so it runs
the same from any folder.  A committed certificate of another vehicle than the
notebook's is refused in one line (:func:`notebook_certificate`).
"""

from __future__ import annotations

import os
from pathlib import Path

from nniquad.certificates.certificate import Certificate, read_certificate
from nniquad.errors import NniquadError
from nniquad.model.vehicle import Vehicle, load_vehicle

__all__ = ["NOTEBOOK_VEHICLE_ENV", "NOTEBOOK_DATA_ENV", "notebook_vehicle", "notebook_data", "notebook_certificate"]

#: Environment variable naming the vehicle file (TOML or JSON) the notebooks study; unset: the paper's vehicle.
NOTEBOOK_VEHICLE_ENV = "NNIQUAD_VEHICLE"
#: Environment variable naming the folder of the notebooks' designs; unset: ``notebooks/data`` of the checkout.
NOTEBOOK_DATA_ENV = "NNIQUAD_NOTEBOOK_DATA"


def notebook_vehicle() -> Vehicle:
    """The vehicle the notebooks study: the file ``$NNIQUAD_VEHICLE`` names, else the paper's vehicle.

    Raises
    ------
    VehicleError
        The file cannot be read or is not a vehicle (one line).
    """
    path = os.environ.get(NOTEBOOK_VEHICLE_ENV, "").strip()
    return load_vehicle(path or None)


def notebook_data(*parts: str) -> Path:
    """A path in the notebooks' data folder, whatever the working folder.

    The folder is ``$NNIQUAD_NOTEBOOK_DATA`` when set, else ``notebooks/data`` of the
    source checkout this package is imported from (the notebooks and their data are
    repository files, not installed with the package).

    Parameters
    ----------
    parts
        Path components below the folder (``"designs", "pd_filtered.json"``).

    Raises
    ------
    NniquadError
        The folder does not exist (one line naming it and the variable).
    """
    given = os.environ.get(NOTEBOOK_DATA_ENV, "").strip()
    # design/nniquad/reporting/notebooks.py -> the checkout's root is three folders above the package
    folder = Path(given) if given else Path(__file__).resolve().parents[3] / "notebooks" / "data"
    if not folder.is_dir():
        raise NniquadError(f"the notebooks' data folder {folder} does not exist: run from a source checkout or set "
                           f"{NOTEBOOK_DATA_ENV} to the folder")
    return folder.joinpath(*parts)


def notebook_certificate(*parts: str, vehicle: Vehicle) -> Certificate:
    """A committed certificate of the notebooks' data folder, refused unless it certifies ``vehicle``.

    Parameters
    ----------
    parts
        Its path below the data folder (:func:`notebook_data`).
    vehicle
        The notebook's vehicle (:func:`notebook_vehicle`).

    Raises
    ------
    CertificateError
        Not a certificate (form, digest).
    NniquadError
        It certifies another vehicle (one line: the committed designs are the paper vehicle's).
    """
    path = notebook_data(*parts)
    cert = read_certificate(path)
    if cert.vehicle != vehicle:
        raise NniquadError(f"{path.name} certifies {cert.vehicle.name!r} ({cert.vehicle.m:g} kg), not the notebook's "
                           f"vehicle {vehicle.name!r} ({vehicle.m:g} kg): this notebook compares committed designs; "
                           f"set {NOTEBOOK_DATA_ENV} to a folder of designs made for that vehicle "
                           "(notebooks/data/make_data.py)")
    return cert
