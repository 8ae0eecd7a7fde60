"""xarray's duck-array checks without importing dask.array and pint in every process.

xarray asks, for every array it wraps, whether it is a dask array or a pint quantity
(``isinstance(data, dask.array.Array)``, ``isinstance(data, pint.Quantity)``). To get those
classes it imports ``dask.array`` (which imports scipy) and ``pint`` on the first check of a
process: about 0.4 CPU-s, a third of a small workflow job, in processes that never make a
dask array or a quantity.

An object can only be an instance of a class that exists, so as long as ``dask.array`` (or
``pint``) has not been imported, no array is one. :func:`defer_duck_array_imports` gives
xarray a record of each of the two libraries that answers from :data:`sys.modules` at the
time of the check: no class while the library is not imported, its class once it is (a
process that makes dask arrays imports ``dask.array`` first, and from then on xarray sees
them as before). xarray has no option for this, hence the record is put into its cache of
duck-array libraries (``xarray.namedarray.pycompat._cached_duck_array_modules``); if that
cache is not there (another xarray), nothing is changed and xarray imports as before.
"""

from __future__ import annotations

import builtins
import sys
from types import ModuleType
from typing import Any

__all__ = ["ImportedDuckArrayModule", "defer_duck_array_imports"]

#: xarray's name of the library -> (module defining the array class, class name)
DEFERRED: dict[str, tuple[str, str]] = {"dask": ("dask.array", "Array"), "pint": ("pint", "Quantity")}


class ImportedDuckArrayModule:
    """xarray's record of a duck-array library (``module``, ``type``, ``version``, ``available``),
    read from the modules imported at the time of each access.

    Parameters
    ----------
    array_module : str
        Module defining the array class (``"dask.array"``, ``"pint"``).
    class_name : str
        Name of the array class in that module.
    """

    def __init__(self, array_module: str, class_name: str) -> None:
        self.array_module = array_module
        self.class_name = class_name

    @property
    def module(self) -> ModuleType | None:
        """The top-level package once the array module is imported (and initialised), else None."""
        if self._array_class() is None:
            return None
        return sys.modules.get(self.array_module.split(".")[0])

    @property
    def type(self) -> tuple[builtins.type, ...]:
        """The array class once its module is imported, else the empty tuple (no instance can exist)."""
        cls = self._array_class()
        return () if cls is None else (cls,)

    @property
    def available(self) -> bool:
        """Whether the array module is imported."""
        return self._array_class() is not None

    @property
    def version(self) -> Any:
        """The package version (``packaging.version.Version``; 0.0.0 while not imported)."""
        from packaging.version import Version

        mod = self.module
        return Version(getattr(mod, "__version__", "0.0.0") if mod is not None else "0.0.0")

    def _array_class(self) -> builtins.type | None:
        mod = sys.modules.get(self.array_module)
        cls = getattr(mod, self.class_name, None) if mod is not None else None
        return cls if isinstance(cls, builtins.type) else None


def defer_duck_array_imports() -> bool:
    """Let xarray check for dask arrays and pint quantities without importing the two libraries.

    Puts an :class:`ImportedDuckArrayModule` for ``dask`` and ``pint`` into xarray's cache of
    duck-array libraries, unless xarray already has a record of them.

    Returns
    -------
    bool
        True if xarray's cache was found (the records are in place), False if this xarray has
        no such cache (nothing changed).
    """
    try:
        from xarray.namedarray import pycompat
    except ImportError:  # pragma: no cover - an xarray without namedarray
        return False
    cache = getattr(pycompat, "_cached_duck_array_modules", None)
    if not isinstance(cache, dict):
        return False
    for name, (array_module, class_name) in DEFERRED.items():
        cache.setdefault(name, ImportedDuckArrayModule(array_module, class_name))
    return True
