"""The dronewind command: --help with examples, every subcommand documented."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from dronewind.cli import SUBCOMMANDS, build_parser

EXE = Path(sys.executable).with_name("dronewind")


def test_help_lists_subcommands_and_examples():
    proc = subprocess.run([str(EXE), "--help"], capture_output=True, text=True, check=True)
    for cmd in SUBCOMMANDS:
        assert cmd.name in proc.stdout
    assert "examples:" in proc.stdout


def test_each_subcommand_has_help_with_example():
    parser = build_parser()
    for cmd in SUBCOMMANDS:
        proc = subprocess.run([str(EXE), cmd.name, "--help"], capture_output=True, text=True, check=True)
        assert "example" in proc.stdout, f"{cmd.name} --help shows no example"
    assert parser.prog == "dronewind"
