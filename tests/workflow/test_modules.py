"""The library's modules stay small enough to be read as one topic each.

A module that grows past :data:`MAX_LINES` holds more than one topic; it is split into modules
named for what they hold (as ``diagnose.calibration`` and ``diagnose.reference``, or
``plan.power`` and ``plan.simulation``), never left to grow.
"""

from __future__ import annotations

from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "src" / "dronewind"

#: Most lines of one module of the library.
MAX_LINES = 800


def long_modules(root: Path, max_lines: int = MAX_LINES) -> dict[str, int]:
    """Modules under ``root`` with more than ``max_lines`` lines: path relative to ``root`` -> lines."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        n = len(path.read_text(encoding="utf-8").splitlines())
        if n > max_lines:
            out[str(path.relative_to(root))] = n
    return out


def test_no_module_of_the_library_is_over_the_limit() -> None:
    assert PACKAGE.is_dir()
    assert long_modules(PACKAGE) == {}


def test_the_check_finds_a_long_module(tmp_path: Path) -> None:
    (tmp_path / "short.py").write_text("x = 1\n" * MAX_LINES)
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "long.py").write_text("x = 1\n" * (MAX_LINES + 1))
    assert long_modules(tmp_path) == {"sub/long.py": MAX_LINES + 1}
