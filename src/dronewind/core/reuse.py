"""Results of pure array computations reused across the runs of one forward flight.

The diagnosis runs a flight's forward model about 36 times (baseline seeds and probes) with
common random numbers: a probe changes one instrument's record and leaves the rest
bit-identical, so some steps deep inside the chain (e.g. despiking a sonic channel the probe
did not touch) get the same input again. :class:`dronewind.diagnose.forward.ForwardCache`
keeps whole products (an L1, an L2) when every input record is unchanged; this module lets a
step inside a product reuse its result when only its own input is unchanged.

A step calls :func:`reused` with a kind, the arrays and settings its result depends on and
a function that computes it. Outside a :func:`reusing` block (every workflow job, every
test, every measured flight) that function is simply called. Inside, the block's
:class:`StepStore` is asked for an earlier result of the same kind and settings whose input
arrays are bit for bit those given, so a reused result is exactly what the step would
compute: the step stays a pure function of its arguments, and the store is scoped to the
block (a :mod:`contextvars` variable, no module state).

The inputs are compared, not hashed: a store holds few results per kind and setting (those
of a flight's first run), and comparing the bytes of two arrays costs about a twentieth of
their SHA-256 (0.11 against 2.0 ms for 3.7 MB, the INS arrays of a 22-minute flight).
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
from collections.abc import Callable, Iterator, Mapping
from typing import Any, TypeVar

import numpy as np
import xarray as xr

__all__ = ["StepStore", "reusing", "reused", "read_only", "same_bits"]

T = TypeVar("T")

#: Unsigned integer types by item size, to compare arrays bit for bit (NaN equal to NaN).
_UINTS: dict[int, type[np.unsignedinteger[Any]]] = {1: np.uint8, 2: np.uint16, 4: np.uint32, 8: np.uint64}
#: Rows compared first: two different records of a flight's runs mostly differ there already
#: (a probe's noise, a shifted clock), so they are told apart without reading them whole;
#: equal ones are then compared whole.
_LEADING_ROWS = 64


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two arrays have the same dtype, shape and bytes (NaN payloads included).

    Parameters
    ----------
    a, b : numpy.ndarray
        Arrays of a numeric or boolean dtype (object arrays are refused).

    Returns
    -------
    bool
    """
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype.kind == "O":
        raise TypeError("same_bits: object arrays have no bytes to compare")
    uint = _UINTS.get(a.dtype.itemsize)
    if uint is None or a.ndim == 0:
        a, b, uint = np.ascontiguousarray(a).reshape(-1), np.ascontiguousarray(b).reshape(-1), np.uint8
    if a.shape[0] > 4 * _LEADING_ROWS and not np.array_equal(a[:_LEADING_ROWS].view(uint),
                                                            b[:_LEADING_ROWS].view(uint)):
        return False
    return bool(np.array_equal(a.view(uint), b.view(uint)))


def read_only(value: T) -> T:
    """``value`` with every array in it marked read-only: itself, or inside tuples, lists,
    dictionaries and dataclasses (nested). Returns ``value``.

    A result that may be handed out again (:func:`reused`, a truth's remembered draws) must
    not be changed by the one who gets it; a caller that needs to change it copies it. Of an
    xarray dataset or data array, the NumPy arrays of its variables are marked (index
    variables are pandas indexes, immutable already).
    """
    if isinstance(value, np.ndarray):
        value.setflags(write=False)
    elif isinstance(value, (xr.Dataset, xr.DataArray)):
        variables = value.variables if isinstance(value, xr.Dataset) else {None: value.variable,
                                                                              **value.coords.variables}
        for var in variables.values():
            # the NumPy array the variable holds, if it holds one: asking a lazily loaded
            # variable for its data would read it
            data = getattr(var, "_data", None)
            if isinstance(data, np.ndarray) and not isinstance(var, xr.IndexVariable):
                data.setflags(write=False)
    elif isinstance(value, (tuple, list)):
        for item in value:
            read_only(item)
    elif isinstance(value, dict):
        for item in value.values():
            read_only(item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            read_only(getattr(value, f.name))
    return value


class StepStore:
    """Results of :func:`reused` steps, found by kind, settings and bit-identical inputs.

    Parameters
    ----------
    frozen : callable, optional
        Returns True once the store should only be read (e.g. after a forward flight's first
        run, :class:`dronewind.diagnose.forward.ForwardCache`); never by default.

    Attributes
    ----------
    hits, misses : int
        Results found and computed.
    """

    def __init__(self, frozen: Callable[[], bool] | None = None) -> None:
        self._entries: dict[tuple[str, str], list[tuple[dict[str, np.ndarray], Any]]] = {}
        self._frozen = frozen or (lambda: False)
        self.hits = 0
        self.misses = 0

    @property
    def frozen(self) -> bool:
        """Whether new results are no longer stored."""
        return bool(self._frozen())

    def get(self, kind: str, settings: str, arrays: Mapping[str, np.ndarray], make: Callable[[], T]) -> T:
        """The result of step ``kind`` for these settings and inputs, made by ``make()`` if absent.

        A result made while the store is open is stored with copies of its inputs (so that
        a caller changing its arrays later cannot change what is found).
        """
        entries = self._entries.setdefault((kind, settings), [])
        for inputs, result in entries:
            if inputs.keys() == arrays.keys() and all(same_bits(inputs[k], arrays[k]) for k in inputs):
                self.hits += 1
                return result
        self.misses += 1
        result = make()
        if not self.frozen:
            entries.append(({k: np.array(v, copy=True) for k, v in arrays.items()}, result))
        return result


_STORE: contextvars.ContextVar[StepStore | None] = contextvars.ContextVar("dronewind_step_store", default=None)


@contextlib.contextmanager
def reusing(store: StepStore) -> Iterator[StepStore]:
    """Let :func:`reused` steps inside the block keep and find their results in ``store``.

    Parameters
    ----------
    store : StepStore
        The store (one forward flight's, :attr:`dronewind.diagnose.forward.ForwardCache.steps`).

    Yields
    ------
    StepStore
        ``store``.
    """
    token = _STORE.set(store)
    try:
        yield store
    finally:
        _STORE.reset(token)


def reused(kind: str, arrays: Mapping[str, Any], settings: str, make: Callable[[], T]) -> T:
    """``make()``, or its earlier result for identical inputs inside a :func:`reusing` block.

    Parameters
    ----------
    kind : str
        Name of the step (results of different steps never meet).
    arrays : mapping of str to array-like
        Every array the result depends on (numeric or boolean).
    settings : str
        Every other argument the result depends on, as text (``repr`` of the scalars: the
        shortest text that reads back as the same float).
    make : callable
        Computes the result; it must depend on ``arrays`` and ``settings`` only.

    Returns
    -------
    object
        The result of ``make()``, its arrays read-only (:func:`read_only`) inside a block or
        not, as a reused result is handed out again: a caller that changes it copies it.
    """
    store = _STORE.get()
    if store is None:
        return read_only(make())
    return store.get(kind, settings, {k: np.asarray(v) for k, v in arrays.items()}, lambda: read_only(make()))
