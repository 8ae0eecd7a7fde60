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


def test_show_config_prints_the_defaults_under_the_given_settings(tmp_path):
    import yaml

    from dronewind.manifest import default_config

    override = tmp_path / "spectra.yaml"
    override.write_text("processing:\n  spectra:\n    segments: 5\n")
    proc = subprocess.run([str(EXE), "show-config", str(override)], capture_output=True, text=True, check=True)
    shown = yaml.safe_load(proc.stdout)
    expected = default_config()
    expected["processing"]["spectra"]["segments"] = 5
    assert shown == expected
