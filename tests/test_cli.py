"""The CLI: every sub-command has a working --help."""

from __future__ import annotations

import subprocess
import sys

import pytest

from nniquad.cli.main import _available_commands


@pytest.mark.parametrize("command", sorted(_available_commands()))
def test_every_command_has_help(command, run_cli):
    code, out, err = run_cli(command, "--help")
    assert code == 0
    assert "usage: nniquad" in out and command in out


def test_top_level_help_lists_commands(run_cli):
    code, out, _ = run_cli("--help")
    assert code == 0
    for command in _available_commands():
        assert command in out


def test_console_script_installed():
    out = subprocess.run([sys.executable, "-m", "nniquad", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and "nniquad" in out.stdout
