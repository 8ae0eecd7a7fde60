"""Results of pure array computations reused across the runs of one forward flight.

The diagnosis runs a flight's forward model about 36 times (baseline seeds and probes) with
common random numbers: a probe changes one instrument's record and leaves the rest
bit-identical, so some steps deep inside the chain (e.g. despiking a sonic channel the probe
did not touch) get the same input again. :class:`dronewind.diagnose.forward.ForwardCache`
keeps whole products (an L1, an L2) when every input record is unchanged; this module lets a
step inside a product reuse its result when only its own input is unchanged.

A step calls :func:`reused` with a kind, the arrays and settings its result depends on and
a function that computes it. Outside a :func:`reusing` block (every workflow job, every
test, every measured flight) that function is simply called. Inside, the result is looked up
in the store by a digest of the step's inputs (:func:`dronewind.core.raw.content_digest`),
so a reused result is exactly what the step would compute: the step stays a pure function
of its arguments, and the store is scoped to the block (a :mod:`contextvars` variable, no
module state).
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator, Mapping
from typing import Any, Protocol, TypeVar

from dronewind.core.raw import content_digest

__all__ = ["ResultStore", "reusing", "reused"]

T = TypeVar("T")


class ResultStore(Protocol):
    """Where :func:`reused` keeps results (:class:`dronewind.diagnose.forward.ForwardCache`)."""

    def get(self, kind: str, key: str, make: Callable[[], Any]) -> Any:
        """The result ``kind`` for inputs with digest ``key``, made by ``make()`` if absent."""


_STORE: contextvars.ContextVar[ResultStore | None] = contextvars.ContextVar("dronewind_result_store", default=None)


@contextlib.contextmanager
def reusing(store: ResultStore) -> Iterator[ResultStore]:
    """Let :func:`reused` steps inside the block keep and find their results in ``store``.

    Parameters
    ----------
    store : ResultStore
        The store (one forward flight's :class:`~dronewind.diagnose.forward.ForwardCache`).

    Yields
    ------
    ResultStore
        ``store``.
    """
    token = _STORE.set(store)
    try:
        yield store
    finally:
        _STORE.reset(token)


def reused(kind: str, arrays: Mapping[str, object], settings: str, make: Callable[[], T]) -> T:
    """``make()``, or its earlier result for identical inputs inside a :func:`reusing` block.

    Parameters
    ----------
    kind : str
        Name of the step (results of different steps never meet).
    arrays : mapping of str to array-like
        Every array the result depends on.
    settings : str
        Every other argument the result depends on, as text (e.g. ``repr`` of the scalars).
    make : callable
        Computes the result; it must depend on ``arrays`` and ``settings`` only. Results
        should be read-only (a reused result is handed out again).

    Returns
    -------
    object
        The result of ``make()``.
    """
    store = _STORE.get()
    if store is None:
        return make()
    result: T = store.get(kind, content_digest(arrays, prefix=settings), make)
    return result
