"""The notebooks' grid size: ``full`` unless ``NNIQUAD_NOTEBOOK_SIZE`` says ``smoke``; anything else is refused."""

from __future__ import annotations

import pytest

import nniquad as nq
from nniquad.errors import NniquadError
from nniquad.reporting.display import NOTEBOOK_SIZE_ENV, NOTEBOOK_SIZES, notebook_size, sized


def test_unset_or_empty_is_full_size(monkeypatch):
    monkeypatch.delenv(NOTEBOOK_SIZE_ENV, raising=False)
    assert notebook_size() == "full" and sized(40, 14) == 40
    monkeypatch.setenv(NOTEBOOK_SIZE_ENV, "  ")
    assert notebook_size() == "full" and sized((1, 2, 3), (2,)) == (1, 2, 3)


def test_smoke_picks_the_second_value(monkeypatch):
    monkeypatch.setenv(NOTEBOOK_SIZE_ENV, "smoke")
    assert notebook_size() == "smoke" and sized(40, 14) == 14
    # the package's top level hands out the same functions the notebooks import
    assert nq.sized is sized and nq.notebook_size is notebook_size
    assert NOTEBOOK_SIZES == ("full", "smoke")


@pytest.mark.parametrize("value", ["Smoke", "quick", "0", "full,smoke"])
def test_any_other_value_is_refused_in_one_line_naming_it(monkeypatch, value):
    monkeypatch.setenv(NOTEBOOK_SIZE_ENV, value)
    with pytest.raises(NniquadError) as err:
        sized(40, 14)
    message = str(err.value)
    assert "\n" not in message and repr(value) in message and NOTEBOOK_SIZE_ENV in message
