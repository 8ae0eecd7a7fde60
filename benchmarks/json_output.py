"""The benchmarks' last step: the result printed as JSON and written to ``--out`` when given."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def print_and_write(result: Any, out: Path | None, indent: int = 1) -> None:
    """Print ``result`` as JSON and write the same text to ``out`` (its folder created) when given.

    Parameters
    ----------
    result : JSON-serialisable
        The benchmark's result.
    out : Path, optional
        File to write (``--out``).
    indent : int
        JSON indentation.
    """
    text = json.dumps(result, indent=indent)
    print(text)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text + "\n")
