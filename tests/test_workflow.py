"""The Snakemake workflow: lint, formatting, DAG on the default config, rule conventions."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def run(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(list(args), cwd=REPO, capture_output=True, text=True, timeout=timeout, check=False)


def test_snakemake_lint_is_clean():
    proc = run(str(BIN / "snakemake"), "--lint")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Congratulations" in proc.stdout + proc.stderr


def test_snakefmt_formatting():
    proc = run(str(BIN / "snakefmt"), "--check", "Snakefile", "workflow/rules")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_dry_run_builds_dag_on_default_config():
    proc = run(str(BIN / "snakemake"), "-n", "--quiet", "rules")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_every_rule_has_log_benchmark_and_conda():
    text = "\n".join(p.read_text() for p in sorted((REPO / "workflow/rules").glob("*.smk")))
    rules = re.split(r"^rule ", text, flags=re.M)[1:]
    assert rules, "no rules found"
    for body in rules:
        name = body.split(":", 1)[0]
        if name == "all":
            continue
        for directive in ("log:", "benchmark:", "conda:"):
            assert directive in body, f"rule {name} lacks {directive}"


def test_bad_manifest_stops_before_any_job(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nsite: {latitude: 43, longitude: 0.3, altitude_m: 600}\n"
                   "masts: []\npayload_flights:\n  - {id: s1, reference: nowhere, sonic: {file: a}, ins: {file: b}}\n")
    proc = run(str(BIN / "snakemake"), "-n", "--config", f"campaign={bad}")
    assert proc.returncode != 0
    out = proc.stdout + proc.stderr
    assert str(bad) in out and "payload_flights[0].reference" in out, out[-2000:]


def test_scripts_take_params_not_the_whole_config():
    """Each rule passes the settings it uses as params; no script reads snakemake.config."""
    for script in sorted((REPO / "scripts").glob("*.py")):
        assert ".config" not in script.read_text(), f"{script.name} reads the whole config"
