"""Error types shared by every dronewind module.

Every error raised for bad input names *where* (file, line, variable or key path)
and *what was expected*, so that a user can fix the input without reading code.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path


class DronewindError(Exception):
    """Base class of all dronewind errors."""


class InputError(DronewindError, ValueError):
    """Bad input data or settings.

    Parameters
    ----------
    where : str or Path
        The file (and optionally ``:line``) or setting the problem is in; anything whose
        ``str`` names it (e.g. an in-memory record of :mod:`dronewind.core.raw`, which
        names the file it stands for).
    what : str
        What is wrong and what was expected.
    """

    def __init__(self, where: str | os.PathLike[str] | object, what: str) -> None:
        self.where = str(where)
        self.what = what
        super().__init__(f"{self.where}: {what}")

    def __reduce__(self) -> tuple:
        # picklable (multiprocessing workers, Snakemake): rebuilt from the same arguments
        return (type(self), (self.where, self.what))


class ManifestError(InputError):
    """A campaign manifest that fails validation (names the manifest and key path)."""

    def __init__(self, manifest: str | Path, key_path: str, what: str) -> None:
        self.manifest = str(manifest)
        self.key_path = key_path
        super().__init__(f"{manifest} [{key_path}]", what)

    def __reduce__(self) -> tuple:
        return (type(self), (self.manifest, self.key_path, self.what))


class ProcessingError(DronewindError, RuntimeError):
    """A processing step that cannot produce a trustworthy result (e.g. no convergence)."""


def describe_header(found: Sequence[str], expected: Sequence[str]) -> str:
    """How a header line differs from the expected one, quoting only the expected names.

    What a reader echoes from a file is limited to what it expected to find there: a file
    that is not what the manifest says (another CSV, a system file) must not have its
    content copied into messages and logs. Unexpected fields are counted, never quoted.

    Parameters
    ----------
    found : sequence of str
        Fields of the header line as read (stripped).
    expected : sequence of str
        The expected field names, in order.

    Returns
    -------
    str
        E.g. ``"header has 7 fields, expected 5 (rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c);
        missing: w_ms; 2 unexpected fields"``.
    """
    found = [str(f).strip() for f in found]
    missing = [e for e in expected if e not in found]
    n_unexpected = sum(1 for f in found if f not in expected)
    parts = [f"header has {len(found)} field{'s' if len(found) != 1 else ''}, expected {len(expected)} "
             f"({','.join(expected)})"]
    if missing:
        parts.append(f"missing: {', '.join(missing)}")
    if n_unexpected:
        parts.append(f"{n_unexpected} unexpected field{'s' if n_unexpected != 1 else ''}")
    if not missing and not n_unexpected and list(found) != list(expected):
        dup = sorted({f for f in found if found.count(f) > 1})
        parts.append(f"repeated: {', '.join(dup)}" if dup else "the expected fields in another order")
    return "; ".join(parts)
