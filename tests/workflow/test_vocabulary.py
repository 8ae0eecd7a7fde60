"""The repository speaks only of what the product is: no labels of how or when it was built.

Every tracked text file (code, docs, configs, tests, benchmarks and their result files) is
searched for the vocabulary of a development diary: numbered work periods and tickets, the
numbered paper labels that stood in for citations (the papers are cited by authors and year:
Ghirardelli et al. 2025, Wetz et al. 2021, Kistner et al. 2024), and result files tagged with
a work period. Git keeps the history; the tree holds the current state.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

#: Patterns of development-history vocabulary, each with what it stands for. Written with a
#: character class in the middle so that this file does not match itself.
FORBIDDEN: dict[str, re.Pattern[str]] = {
    "numbered work period": re.compile(r"\bsessio[n]s?\s+\d+", re.IGNORECASE),
    "work-period label": re.compile(r"\bwork[- ]perio[d]s?\b", re.IGNORECASE),
    "numbered ticket": re.compile(r"\b(?:issu[e]s?|ticke[t]s?)\s+#?\d+\b", re.IGNORECASE),
    "numbered paper label": re.compile(r"\bsee[d][ _]?00[0-9]\b", re.IGNORECASE),
    "result file tagged with a work period":
        re.compile(r"[A-Za-z0-9]_[s](?:1[3-9]|[2-9]\d)(?:_[a-z]+)*\.(?:json|txt|csv|md|log)\b"),
}

#: A period number for the check's own example of a tagged result file.
_PERIOD = 27

#: Real records are data written by others; they are not the product's words.
EXEMPT_PREFIXES = ("tests/data/",)


def _tracked_text_files() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: the tracked files are unknown")
    files = []
    for name in out.decode().split("\0"):
        if not name or name.startswith(EXEMPT_PREFIXES):
            continue
        path = REPO / name
        if path.is_file() and not path.is_symlink():
            files.append(path)
    return files


def find_vocabulary(text: str) -> list[tuple[int, str, str]]:
    """Lines of ``text`` that carry development-history vocabulary: (line number, kind, match)."""
    hits = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        for kind, pattern in FORBIDDEN.items():
            match = pattern.search(line)
            if match:
                hits.append((lineno, kind, match.group(0)))
    return hits


@pytest.mark.parametrize(("text", "kind"), [
    ("the code of sessi" "on 27 took 123 s", "numbered work period"),
    ("issu" "e 14's targets", "numbered ticket"),
    ("(see" "d 000, Sect. 2.3)", "numbered paper label"),
    (f"benchmarks/results/compliance_s{_PERIOD}.json", "result file tagged with a work period"),
])
def test_the_check_finds_each_kind(text: str, kind: str) -> None:
    assert [k for _, k, _ in find_vocabulary(text)] == [kind]


@pytest.mark.parametrize("text", [
    "results/mosai2023/netcdf/L4/s01_drone.nc", "mast30_s01.dat:2: required column(s) Uz missing",
    "Ghirardelli et al. (2025), Eq. 4", "random seed 12345", "diagnosis/measured/s10.json",
])
def test_the_check_passes_the_products_words(text: str) -> None:
    assert find_vocabulary(text) == []


def test_no_development_history_in_the_repository() -> None:
    offenders = []
    for path in _tracked_text_files():
        rel = path.relative_to(REPO).as_posix()
        if path.resolve() == Path(__file__).resolve():
            continue
        for kind, pattern in FORBIDDEN.items():
            if pattern.search(rel):
                offenders.append(f"{rel}: file name is a {kind}")
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue  # binary files (figures, NetCDF) carry no prose
        offenders += [f"{rel}:{n}: {kind} ({m!r})" for n, kind, m in find_vocabulary(text)]
    assert not offenders, f"{len(offenders)} lines speak of how the project was built:\n" + "\n".join(offenders[:60])
