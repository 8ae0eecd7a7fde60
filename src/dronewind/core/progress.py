"""Progress of a long step: one log line per finished item, with its count and elapsed time.

A job that works for a minute says what it has done so far, in its log file and on the
terminal (``figure 3/14 fig09_velocity_spectra drawn in 4.2 s``,
``probe 5/27 flight s01 mast_tilt tilt_deg=2 run in 3.1 s``).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["Progress"]


class Progress:
    """Counter of a stage's items that logs each finished one.

    Parameters
    ----------
    stage : str
        What an item is (``"figure"``, ``"probe"``).
    total : int
        Number of items of the stage.
    verb : str
        What was done to an item (``"drawn"``, ``"run"``).
    logger : logging.Logger, optional
        Where the lines go; default the ``dronewind`` logger.
    """

    def __init__(self, stage: str, total: int, verb: str = "done", logger: logging.Logger | None = None) -> None:
        self.stage = stage
        self.total = int(total)
        self.verb = verb
        self.done = 0
        self.log = logger if logger is not None else logging.getLogger("dronewind")
        self._start = time.perf_counter()

    @contextmanager
    def item(self, name: str) -> Iterator[None]:
        """Time one item; log ``<stage> <i>/<total> <name> <verb> in <s> s`` when it finishes.

        An item that raises is not counted and its error propagates (the caller decides
        whether it is skipped, :meth:`skipped`, or stops the step).
        """
        start = time.perf_counter()
        yield
        self.done += 1
        index = self.done
        self.log.info("%s %d/%d %s %s in %.1f s", self.stage, index, self.total, name, self.verb,
                      time.perf_counter() - start)

    def add(self, name: str, seconds: float) -> None:
        """Count an item done elsewhere (in a worker process) that took ``seconds``; log it as :meth:`item` does."""
        self.done += 1
        self.log.info("%s %d/%d %s %s in %.1f s", self.stage, self.done, self.total, name, self.verb, seconds)

    def skipped(self, name: str, reason: str) -> None:
        """Count an item that was not done, logging why (a warning)."""
        self.done += 1
        self.log.warning("%s %d/%d %s skipped: %s", self.stage, self.done, self.total, name, reason)

    def finished(self) -> None:
        """Log the stage's total: items and elapsed time."""
        self.log.info("%s: %d/%d %s in %.1f s", self.stage, self.done, self.total, self.verb,
                      time.perf_counter() - self._start)
