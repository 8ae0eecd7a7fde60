"""The dronewind command: --help with examples, every subcommand documented."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

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


# ----------------------------------------------------------------------------- bad input: one line, exit 1


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(EXE), *args], capture_output=True, text=True, check=False)


def assert_one_line_error(proc: subprocess.CompletedProcess, command: str, *fragments: str) -> None:
    assert proc.returncode != 0, proc.stdout
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"dronewind {command}: error: "), proc.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


@pytest.fixture()
def bad_inputs(tmp_path):
    """A missing file, a text file that is not NetCDF, a binary file, a bad YAML and a bad manifest."""
    not_nc = tmp_path / "notes.nc"
    not_nc.write_text("not a NetCDF file\n")
    binary = tmp_path / "garbage.bin"
    binary.write_bytes(bytes(range(256)) * 4)
    bad_yaml = tmp_path / "broken.yaml"
    bad_yaml.write_text("processing: [\n")
    bad_manifest = tmp_path / "manifest.yaml"
    bad_manifest.write_text("name: bad\nsite: {latitude: 43, longitude: 0.3, altitude_m: 600}\nmasts: []\n"
                            "payload_flights:\n  - {id: s1, reference: nowhere, sonic: {file: a}, ins: {file: b}}\n")
    return {"missing": tmp_path / "missing.nc", "not_nc": not_nc, "binary": binary, "bad_yaml": bad_yaml,
            "bad_manifest": bad_manifest}


def test_check_cf_bad_input(bad_inputs):
    assert_one_line_error(run_cli("check-cf", str(bad_inputs["missing"])), "check-cf", "missing.nc: no such file")
    assert_one_line_error(run_cli("check-cf", str(bad_inputs["not_nc"])), "check-cf", "notes.nc: not a NetCDF file")
    assert_one_line_error(run_cli("check-cf", str(bad_inputs["bad_manifest"])), "check-cf", "not a NetCDF file")
    assert_one_line_error(run_cli("check-cf", str(bad_inputs["not_nc"].parent)), "check-cf", "not a file")


def test_check_cf_reports_each_bad_file_and_checks_the_good_ones(bad_inputs, tmp_path):
    from tests.core.test_cf import write

    good = write(tmp_path / "mast.nc")
    proc = run_cli("check-cf", str(bad_inputs["missing"]), str(good))
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert f"{good}: passes" in proc.stdout and "missing.nc: no such file" in proc.stderr
    plain = run_cli("check-cf", "--plain", str(good))  # the checker as installed: the same verdict
    assert plain.returncode == 0 and f"{good}: passes" in plain.stdout


def test_validate_campaign_bad_input(bad_inputs):
    assert_one_line_error(run_cli("validate-campaign", str(bad_inputs["missing"])), "validate-campaign",
                          "missing.nc", "does not exist")
    assert_one_line_error(run_cli("validate-campaign", str(bad_inputs["not_nc"])), "validate-campaign",
                          "notes.nc", "expected a mapping")
    assert_one_line_error(run_cli("validate-campaign", str(bad_inputs["binary"])), "validate-campaign",
                          "garbage.bin")
    assert_one_line_error(run_cli("validate-campaign", str(bad_inputs["bad_yaml"])), "validate-campaign",
                          "broken.yaml", "not valid YAML")
    assert_one_line_error(run_cli("validate-campaign", str(bad_inputs["bad_manifest"])), "validate-campaign",
                          "manifest.yaml", "payload_flights[0].reference")


def test_show_config_bad_input(bad_inputs, tmp_path):
    assert_one_line_error(run_cli("show-config", str(bad_inputs["missing"])), "show-config", "missing.nc: no such file")
    assert_one_line_error(run_cli("show-config", str(bad_inputs["binary"])), "show-config", "garbage.bin")
    assert_one_line_error(run_cli("show-config", str(bad_inputs["bad_yaml"])), "show-config",
                          "broken.yaml:2: not valid YAML")
    assert_one_line_error(run_cli("show-config", str(bad_inputs["bad_manifest"])), "show-config",
                          "a campaign manifest is given as --config campaign=<manifest>")
    typo = tmp_path / "typo.yaml"
    typo.write_text("processing:\n  rotatoin: double\n")
    assert_one_line_error(run_cli("show-config", str(typo)), "show-config",
                          "processing.rotatoin is not a setting: did you mean 'rotation'?")


# ----------------------------------------------------------------------------- dronewind run


def test_run_wraps_snakemake_then_the_report(tmp_path):
    proc = run_cli("run", "--show", "--cores", "1", "mosai2023", "-n")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert len(lines) == 1  # a dry run writes no report
    assert "snakemake --cores 1 -n --config campaign=" in lines[0]
    assert lines[0].rstrip(")").endswith("config/campaigns/mosai2023.yaml")

    manifest = Path(__file__).resolve().parents[2] / "config" / "campaigns" / "mosai2023.yaml"
    proc = run_cli("run", "--show", str(manifest), "--config", "processing={despike: {n_mad: 5}}",
                   "results_dir=/tmp/r")
    assert proc.returncode == 0, proc.stderr
    run, report = proc.stdout.splitlines()
    # one --config option holding the campaign and the user's settings (Snakemake keeps only the last one)
    assert run.count("--config") == 1 and "'processing={despike: {n_mad: 5}}' results_dir=/tmp/r" in run
    assert "--report /tmp/r/mosai2023/report.html --config campaign=" in report


def test_run_help_and_unknown_campaign():
    proc = run_cli("run", "--help")
    assert proc.returncode == 0 and "dronewind run mosai2023" in proc.stdout and "--dry-run" in proc.stdout
    proc = run_cli("run", "--show", "no_such_campaign")
    assert proc.returncode == 1
    assert "no such manifest file, nor a campaign of config/campaigns/" in proc.stderr and "mosai2023" in proc.stderr


@pytest.mark.slow
def test_run_dry_run_through_snakemake():
    proc = run_cli("run", "--cores", "1", "mosai2023", "--dry-run", "--quiet", "rules")
    assert proc.returncode == 0, proc.stderr[-2000:]
