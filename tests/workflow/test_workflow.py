"""The Snakemake workflow: lint, formatting, DAG on the default config, rule conventions.

The rules are read as Snakemake registers them (``tests/workflow/describe_rules.smk``
includes the Snakefile and writes every rule of ``workflow.rules``), so a rule defined
anywhere, also inside a block or a loop, is checked; the rule sources are then required to
define each registered rule once, at the top level of a rule file.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
DESCRIBE = REPO / "tests" / "workflow" / "describe_rules.smk"
#: Directives every rule but the default target has.
DIRECTIVES = ("log:", "benchmark:", "conda:", "threads:", "resources:")


def run(*args: str, timeout: float = 300, env: dict[str, str] | None = None,
        cwd: Path = REPO) -> subprocess.CompletedProcess:
    return subprocess.run(list(args), cwd=cwd, capture_output=True, text=True, timeout=timeout, check=False,
                          env={**os.environ, **(env or {})})


def registered_rules(snakefile: Path, tmp_path: Path, cwd: Path = REPO) -> list[dict]:
    """Every rule Snakemake registers for ``snakefile`` (through describe_rules.smk)."""
    out = tmp_path / "rules.json"
    wrapper = tmp_path / "describe.smk"
    wrapper.write_text(DESCRIBE.read_text().replace('"../../Snakefile"', json.dumps(str(snakefile))))
    proc = run(str(BIN / "snakemake"), "--snakefile", str(wrapper), "--list-rules",
               env={"DESCRIBE_RULES_JSON": str(out)}, cwd=cwd)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return json.loads(out.read_text())


def top_level_rules(rule_files: list[Path]) -> dict[str, list[str]]:
    """Rule name -> bodies of its top-level definitions (``rule <name>:`` at the start of a line)."""
    found: dict[str, list[str]] = {}
    for path in rule_files:
        parts = re.split(r"^rule (\w+):", path.read_text(), flags=re.M)
        for name, body in zip(parts[1::2], parts[2::2], strict=True):
            # a body ends at the next line that starts at column 0 and is not a comment
            body = re.split(r"^(?=[^\s#])", body, maxsplit=1, flags=re.M)[0]
            found.setdefault(name, []).append(body)
    return found


def convention_problems(rules: list[dict], rule_files: list[Path]) -> list[str]:
    """What breaks the workflow's rule conventions (empty: none)."""
    problems = []
    sources = top_level_rules(rule_files)
    for rule in rules:
        name = rule["name"]
        bodies = sources.get(name, [])
        if len(bodies) != 1:
            problems.append(f"rule {name} is defined {len(bodies)} times at the top level of the rule files")
            continue
        if name == "all":
            continue
        if not (rule["log"] and rule["benchmark"] and rule["conda"]):
            problems.append(f"rule {name} lacks a log, benchmark or conda directive")
        if "mem_mb" not in rule["resources"]:
            problems.append(f"rule {name} has no mem_mb resource")
        problems += [f"rule {name} lacks {d}" for d in DIRECTIVES if f"\n    {d}" not in bodies[0]]
    extra = set(sources) - {r["name"] for r in rules}
    problems += [f"rule {name} is in the sources but not registered" for name in sorted(extra)]
    return problems


def test_snakemake_lint_is_clean():
    proc = run(str(BIN / "snakemake"), "--lint")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Congratulations" in proc.stdout + proc.stderr


def test_snakefmt_formatting():
    proc = run(str(BIN / "snakefmt"), "--check", "Snakefile", "workflow")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_dry_run_builds_dag_on_default_config():
    proc = run(str(BIN / "snakemake"), "-n", "--quiet", "rules")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_every_rule_follows_the_conventions(tmp_path):
    """Each registered rule is defined once at the top level and has log, benchmark, conda, threads, resources."""
    rules = registered_rules(REPO / "Snakefile", tmp_path)
    names = [r["name"] for r in rules]
    assert len(names) == len(set(names)) and len(names) > 30, names
    listed = run(str(BIN / "snakemake"), "--list-rules")
    assert listed.returncode == 0, listed.stderr
    assert {line.split()[0] for line in listed.stdout.splitlines() if line.strip()} == set(names)
    assert convention_problems(rules, [REPO / "Snakefile", *sorted((REPO / "workflow" / "rules").glob("*.smk"))]) == []


@pytest.mark.parametrize("bad", ["loop", "twice", "bare"])
def test_the_convention_check_fails_on_a_rule_that_breaks_them(tmp_path, bad):
    """The check of the test above reports a rule made in a loop, a name defined twice, a rule without directives."""
    rule = ('rule {name}:\n    output:\n        "{name}.txt"\n    log:\n        "{name}.log"\n'
            '    benchmark:\n        "{name}.tsv"\n    threads: 1\n    resources:\n        mem_mb=100,\n'
            '    conda:\n        "env.yaml"\n    shell:\n        "touch {{output}}"\n')
    text = rule.format(name="a")
    if bad == "loop":
        text += "\nfor _n in ['b', 'c']:\n\n    rule:\n        name:\n            f'made_{_n}'\n" \
                "        output:\n            f'{_n}.txt'\n        shell:\n            'touch {output}'\n"
    elif bad == "twice":
        text += "\nif True:\n\n" + "".join("    " + line for line in rule.format(name="a2").splitlines(True))
        text += "\nelse:\n\n" + "".join("    " + line for line in rule.format(name="a2").splitlines(True))
    else:
        text += '\nrule b:\n    output:\n        "b.txt"\n    shell:\n        "touch {output}"\n'
    snakefile = tmp_path / "Snakefile"
    snakefile.write_text(text)
    rules = registered_rules(snakefile, tmp_path, cwd=tmp_path)
    problems = convention_problems(rules, [snakefile])
    assert problems, rules
    expected = {"loop": "made_b is defined 0 times", "twice": "a2 is defined 0 times", "bare": "rule b lacks"}[bad]
    assert any(expected in p for p in problems), problems


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
    scripts = sorted((REPO / "workflow" / "scripts").glob("*.py"))
    assert len(scripts) > 20
    for script in scripts:
        assert ".config" not in script.read_text(), f"{script.name} reads the whole config"


def test_every_rule_script_exists(tmp_path):
    for rule in registered_rules(REPO / "Snakefile", tmp_path):
        if rule["script"] != "None":
            assert (REPO / "workflow" / "rules" / rule["script"]).resolve().is_file(), rule
