"""The README's commands work as written on a fresh clone; the manifest page's examples are valid.

The commands are read from the ``bash`` code blocks of README.md (so the test follows the
README) and run in a fresh copy of the repository (the files a clone has: tracked and
not-ignored ones, no results, no ``.snakemake``) with ``.venv`` pointing to the running
environment. Long commands are dry runs: ``make X`` runs as ``make -n X`` (and the Snakemake
command it would run, with ``-n``), every ``snakemake`` command gets ``-n``. The placeholder
``/abs/path/to/campaign.yaml`` is the embedded default campaign (absolute path). A command
that needs a processed campaign (redrawing, ``check-cf``) gets one first: every output file
of the campaign touched (the redraw dry run must then plan exactly the figure and table
jobs), or real CF files in ``netcdf/L1``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from dronewind.manifest import load_campaign

REPO = Path(__file__).resolve().parents[2]
VENV = Path(sys.executable).parents[1]
PLACEHOLDER = "/abs/path/to/campaign.yaml"
#: the jobs a redraw of the default campaign plans: its figure and table jobs and the target
REDRAW_JOBS = {"all": 1, "tables": 1, "flight_stats": 1, "figures": 1, "figures_appendix": 1, "diagnosis_report": 1,
               "quadrotor_figures": 1, "tunnel_figures": 1, "published_report": 1}


def code_blocks(markdown: str, language: str) -> list[str]:
    """The code blocks of one language in a Markdown text, in order."""
    return re.findall(rf"^ *```{language}\n(.*?)^ *```", markdown, flags=re.S | re.M)


def readme_commands() -> list[str]:
    """Every command of the README's bash blocks (continuation lines joined, comments kept)."""
    commands = []
    for block in code_blocks((REPO / "README.md").read_text(encoding="utf-8"), "bash"):
        for line in block.replace("\\\n", " ").splitlines():
            if line.strip() and not line.lstrip().startswith("#"):
                commands.append(line.strip())
    return commands


def fresh_clone(dest: Path) -> Path:
    """The files a clone of the repository has (tracked and untracked-not-ignored), and .venv."""
    proc = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=REPO,
                          capture_output=True, check=False)
    if proc.returncode == 0:
        for name in filter(None, proc.stdout.decode().split("\0")):
            src, dst = REPO / name, dest / name
            if src.is_file() or src.is_symlink():
                dst.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(src, dst, follow_symlinks=False)
    else:  # not a git checkout: everything but outputs and caches
        shutil.copytree(REPO, dest, symlinks=True, dirs_exist_ok=True, ignore=shutil.ignore_patterns(
            ".git", ".venv", "results", ".snakemake", "__pycache__", "*.egg-info", ".*_cache"))
    (dest / ".venv").symlink_to(VENV, target_is_directory=True)
    return dest


def shell(clone: Path, command: str, timeout: float = 300) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(clone / "src"), "PATH": f"{VENV / 'bin'}:{os.environ.get('PATH', '')}"}
    return subprocess.run(["bash", "-c", command], cwd=clone, capture_output=True, text=True, timeout=timeout,
                          check=False, env=env)


def as_dry_run(command: str) -> str:
    """The command as a dry run: ``-n`` for Snakemake, ``--dry-run`` after the campaign of ``dronewind run``."""
    words = command.split()
    if words[0].endswith("dronewind") and words[1:2] == ["run"]:
        return command if "--dry-run" in words or "-n" in words else f"{command} --dry-run"
    if "snakemake" in command.split()[0] and " -n" not in f" {command}":
        first, _, rest = command.partition(" ")
        return f"{first} -n {rest}"
    return command


def job_stats(output: str) -> dict[str, int]:
    """Rule -> number of jobs, from the "Job stats" table of a Snakemake dry run."""
    lines = output.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Job stats")) + 3
    stats = {}
    for line in lines[start:]:
        parts = line.split()
        if len(parts) != 2 or parts[0] == "total":
            break
        stats[parts[0]] = int(parts[1])
    return stats


def fake_processed_campaign(clone: Path, manifest: Path) -> int:
    """Touch every output of the campaign (what a finished run leaves) in a clone; their number."""
    proc = shell(clone, f".venv/bin/snakemake -n --summary --config campaign={manifest}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("output_file\t"))
    n = 0
    for line in lines[header + 1:]:
        path = clone / line.split("\t")[0]
        path.parent.mkdir(parents=True, exist_ok=True)
        path.touch()
        n += 1
    return n


def real_l1_files(clone: Path) -> list[Path]:
    """Replace the L1 folder of the default campaign by two real CF files."""
    from tests.core.test_cf import write

    folder = clone / "results" / "mosai2023" / "netcdf" / "L1"
    shutil.rmtree(folder, ignore_errors=True)
    return [write(folder / "mast_mast30.nc"), write(folder / "mast_mast60.nc")]


@pytest.fixture(scope="module")
def clone(tmp_path_factory) -> Path:
    return fresh_clone(tmp_path_factory.mktemp("clone") / "dronewind")


def test_readme_has_the_commands_this_test_knows():
    commands = readme_commands()
    assert any(c.startswith("make run") for c in commands) and any(c.startswith("make test") for c in commands)
    assert any("--allowed-rules" in c for c in commands), "the redraw command"
    assert any("check-cf" in c for c in commands)
    assert any(c.startswith(".venv/bin/dronewind run") for c in commands), "the run command"
    text = (REPO / "README.md").read_text()
    assert "docs/manifest.md" in text and "make venv" in text
    # the answer is said before any internals; the README speaks of the product only
    assert text.index("## Where the answer is") < text.index("## From your own files to the answer")
    assert not re.search(r"[Ss]ession \d|_s\d\d\b|sessions? \d", text)
    for word in ("preload", "mallopt", "allocator", "job server", "CPU-s"):
        assert word not in text, word
    for link in re.findall(r"\]\((docs/[^)#]+)", text):
        if link not in ("docs/workflow.md", "docs/design.md", "docs/data-contract.md", "docs/references.md"):
            # (those four are written beside this page)
            assert (REPO / link).is_file(), link


def test_every_readme_command_works_as_written_on_a_fresh_clone(clone):
    manifest = clone / "config" / "campaigns" / "mosai2023.yaml"
    for written in readme_commands():
        command = written.replace(PLACEHOLDER, str(manifest))
        if command.startswith("make "):
            proc = shell(clone, f"make -n {command[5:]}")
            assert proc.returncode == 0, (written, proc.stdout + proc.stderr)
            if command.split()[1] == "venv":  # set-up only
                assert "pip install" in proc.stdout, (written, proc.stdout)
                continue
            inner = [line for line in proc.stdout.splitlines() if line.startswith(".venv/bin/snakemake")
                     and "--report" not in line]  # the report needs a finished run: tested below
            assert inner or "pytest" in proc.stdout, (written, proc.stdout)
            for line in inner:  # the Snakemake command `make run` runs, as a dry run
                sub = shell(clone, as_dry_run(line))
                assert sub.returncode == 0 and "Job stats" in sub.stdout, (line, sub.stderr[-3000:])
            continue
        if "--allowed-rules" in command or "--report" in command:
            # both need a finished run: every output of the campaign stands in for one
            assert fake_processed_campaign(clone, manifest) > 100
        if "check-cf" in command:
            real_l1_files(clone)
        proc = shell(clone, as_dry_run(command))
        assert proc.returncode == 0, (written, (proc.stdout + proc.stderr)[-3000:])
        assert "Traceback" not in proc.stderr, (written, proc.stderr[-3000:])
        if "--allowed-rules" in command:
            # exactly the figure and table jobs of the campaign, nothing upstream
            assert job_stats(proc.stdout) == REDRAW_JOBS, (written, proc.stdout[-3000:])
        if "--report" in command:
            report = clone / command.split("--report", 1)[1].split()[0]
            assert report.is_file() and report.stat().st_size > 100_000, (written, proc.stderr[-3000:])
        if "--allowed-rules" in command or "--report" in command:
            shutil.rmtree(clone / "results")


def test_the_redraw_command_of_a_payload_only_campaign(clone, tmp_path):
    """Rule names a campaign does not have (quadrotor, tunnel, published) are ignored."""
    from tests.small_campaign import write_small_campaign

    manifest = write_small_campaign(tmp_path)
    command = next(c for c in readme_commands() if "--allowed-rules" in c).replace(PLACEHOLDER, str(manifest))
    assert fake_processed_campaign(clone, manifest) > 10
    proc = shell(clone, as_dry_run(command))
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert job_stats(proc.stdout) == {"all": 1, "tables": 1, "flight_stats": 1, "figures": 1, "figures_appendix": 1,
                                      "diagnosis_report": 1}
    shutil.rmtree(clone / "results")


# ----------------------------------------------------------------------------- docs/manifest.md


def manifest_examples() -> list[dict]:
    text = (REPO / "docs" / "manifest.md").read_text(encoding="utf-8")
    return [yaml.safe_load(block) for block in code_blocks(text, "yaml")]


def test_manifest_page_has_an_example_of_every_record_kind():
    examples = manifest_examples()
    kinds = {key for example in examples for key in example if key not in ("name", "site")}
    assert {"masts", "payload_flights", "quadrotor_flights", "tunnel", "simulation"} <= kinds
    assert any(not e.get("simulation") and e.get("masts") and not e.get("payload_flights") for e in examples)


def test_manifest_page_examples_are_valid_manifests(tmp_path):
    from dronewind.simulate.quadrotor import fleet_settings, flight_conditions
    from dronewind.simulate.settings import validate_simulation

    for k, example in enumerate(manifest_examples()):
        folder = tmp_path / f"example{k}"
        folder.mkdir()
        path = folder / "campaign.yaml"
        path.write_text(yaml.safe_dump(example, sort_keys=False))
        if not example.get("simulation"):
            # measured: every file it names must exist (globs must match); create them
            names = [f for m in example.get("masts") or [] for s in m["sonics"] for f in s["files"]]
            names += [f[key]["file"] for f in example.get("payload_flights") or [] for key in ("sonic", "ins")]
            names += [f["reference"] for f in example.get("quadrotor_flights") or [] if isinstance(f["reference"], str)]
            names += [f["file"] for f in example.get("autopilot_flights") or []]
            names += [u["file"] for f in example.get("quadrotor_flights") or [] for u in f["uavs"]]
            names += [example["tunnel"]["runs"]] if example.get("tunnel") else []
            for name in names:
                (folder / name.replace("*", "2023_08_21")).parent.mkdir(parents=True, exist_ok=True)
                (folder / name.replace("*", "2023_08_21")).touch()
        campaign = load_campaign(path)
        assert campaign.simulated == bool(example.get("simulation"))
        if campaign.simulated:
            sim = campaign.data["simulation"]
            validate_simulation(campaign.data)
            fleet_settings(sim.get("quadrotor"))
            for flight in campaign.quadrotor_flights:
                flight_conditions(sim, flight["id"])


def test_manifest_page_virtual_example_plans_every_system(clone, tmp_path):
    """The virtual example builds the workflow's DAG: simulators, payload, quadrotor and tunnel chains."""
    example = next(e for e in manifest_examples() if e.get("simulation"))
    path = tmp_path / "virtual.yaml"
    path.write_text(yaml.safe_dump(example, sort_keys=False))
    proc = shell(clone, f".venv/bin/snakemake -n --config campaign={path}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    rules = job_stats(proc.stdout)
    for rule in ("simulate_payload", "quadrotor_simulate", "quadrotor_fleet", "tunnel_simulate", "l4", "quadrotor_l2",
                 "tunnel_figures", "diagnosis_report"):
        assert rule in rules, (rule, sorted(rules))
