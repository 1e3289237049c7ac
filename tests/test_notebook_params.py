"""The notebooks' parameters: the vehicle from ``$NNIQUAD_VEHICLE``, the data folder whatever the working folder,
and a committed certificate of another vehicle refused in one line."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import nniquad as nq
from nniquad.errors import NniquadError, VehicleError
from nniquad.reporting.notebooks import NOTEBOOK_DATA_ENV, NOTEBOOK_VEHICLE_ENV

ROOT = Path(__file__).resolve().parents[1]
IRIS = ROOT / "notebooks" / "data" / "vehicles" / "iris.toml"


def test_the_vehicle_is_the_papers_unless_named(monkeypatch):
    monkeypatch.delenv(NOTEBOOK_VEHICLE_ENV, raising=False)
    assert nq.notebook_vehicle() == nq.PAPER_VEHICLE
    monkeypatch.setenv(NOTEBOOK_VEHICLE_ENV, str(IRIS))
    v = nq.notebook_vehicle()
    assert v.m == tomllib.loads(IRIS.read_text())["m"] and v.name.startswith("3DR Iris")
    monkeypatch.setenv(NOTEBOOK_VEHICLE_ENV, "/nonexistent/v.toml")
    with pytest.raises(VehicleError):
        nq.notebook_vehicle()


def test_the_data_folder_does_not_depend_on_the_working_folder(monkeypatch, tmp_path):
    monkeypatch.delenv(NOTEBOOK_DATA_ENV, raising=False)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data").mkdir()  # a 'data' folder here must not be taken for the notebooks'
    assert nq.notebook_data("families.json") == ROOT / "notebooks" / "data" / "families.json"
    monkeypatch.setenv(NOTEBOOK_DATA_ENV, str(tmp_path / "data"))
    assert nq.notebook_data("x.json") == tmp_path / "data" / "x.json"
    monkeypatch.setenv(NOTEBOOK_DATA_ENV, str(tmp_path / "missing"))
    with pytest.raises(NniquadError, match=NOTEBOOK_DATA_ENV) as err:
        nq.notebook_data()
    assert "\n" not in str(err.value)


def test_a_certificate_of_another_vehicle_is_refused_in_one_line(monkeypatch):
    monkeypatch.delenv(NOTEBOOK_DATA_ENV, raising=False)
    cert = nq.notebook_certificate("full_model_certificate.json", vehicle=nq.PAPER_VEHICLE)
    assert cert.vehicle == nq.PAPER_VEHICLE
    with pytest.raises(NniquadError) as err:
        nq.notebook_certificate("full_model_certificate.json", vehicle=nq.load_vehicle(IRIS))
    message = str(err.value)
    assert "\n" not in message and "not the notebook's vehicle" in message and NOTEBOOK_DATA_ENV in message
