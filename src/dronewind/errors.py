"""Error types shared by every dronewind module.

Every error raised for bad input names *where* (file, line, variable or key path)
and *what was expected*, so that a user can fix the input without reading code.
"""

from __future__ import annotations

import os
from pathlib import Path


class DronewindError(Exception):
    """Base class of all dronewind errors."""


class InputError(DronewindError, ValueError):
    """Bad input data or settings.

    Parameters
    ----------
    where : str or Path
        The file (and optionally ``:line``) or setting the problem is in.
    what : str
        What is wrong and what was expected.
    """

    def __init__(self, where: str | os.PathLike[str], what: str) -> None:
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
