"""One run at a time on a results folder: a lock file under ``results/<name>/``.

Snakemake's own lock lives in the ``.snakemake/`` folder of the checkout it runs from, so
two checkouts (or two users) writing the same results folder do not see each other, and a
run killed with ``kill -9`` leaves it behind until ``--unlock``. The workflow therefore
takes this lock instead (the ``Snakefile``: ``onstart`` takes it, ``onsuccess``
and ``onerror`` release it; the default profile sets ``nolock: true``):

* ``results/<name>/.dronewind.lock`` is created atomically (a complete temporary file
  hard-linked to the lock name, which fails if it exists) and holds
  the owner's process id, host, checkout, start time and the process start tick (so a
  reused process id is not taken for the owner);
* a lock whose owner is on this host and no longer runs is stale: it is taken over, and
  the message says so (a killed run is resumed by running the same command again);
* a lock of a live process, or of another host (whose processes cannot be checked), stops
  the run with a message naming the owner and, for another host, the file to delete when
  that run is known to be over.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import socket
from pathlib import Path
from typing import Any

from dronewind.errors import DronewindError

__all__ = ["LOCK_NAME", "ResultsLockedError", "acquire_results_lock", "release_results_lock", "lock_owner"]

#: Name of the lock file in ``results/<name>/``.
LOCK_NAME = ".dronewind.lock"


class ResultsLockedError(DronewindError, RuntimeError):
    """Another run holds the results folder."""


def _start_ticks(pid: int) -> int | None:
    """Start time of a process in clock ticks since boot (Linux ``/proc``), or None."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    # field 22 (starttime); the command name (field 2) may hold spaces, so split after ')'
    fields = stat.rsplit(")", 1)[-1].split()
    try:
        return int(fields[19])
    except (IndexError, ValueError):
        return None


def _alive(pid: int, start_ticks: int | None) -> bool:
    """True if process ``pid`` runs and (when known) started at ``start_ticks``."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # it exists, owned by another user
    if start_ticks is not None:
        now = _start_ticks(pid)
        if now is not None and now != start_ticks:
            return False  # the id was reused by another process
    return True


def lock_owner(folder: str | Path) -> dict[str, Any] | None:
    """The content of a results folder's lock file, or None when there is none.

    Parameters
    ----------
    folder : str or Path
        ``results/<name>``.

    Returns
    -------
    dict or None
        ``pid``, ``host``, ``checkout``, ``started`` and ``start_ticks`` (``{}`` if the file
        cannot be parsed).
    """
    path = Path(folder) / LOCK_NAME
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    try:
        data = json.loads(text)
    except json.JSONDecodeError:
        return {}
    return data if isinstance(data, dict) else {}


def _describe(owner: dict[str, Any]) -> str:
    return (f"pid {owner.get('pid', '?')} on host {owner.get('host', '?')}, checkout {owner.get('checkout', '?')}, "
            f"started {owner.get('started', '?')}")


def _write_new(path: Path, record: dict[str, Any]) -> bool:
    """Create the lock file with ``record``, complete or not at all; False if it exists.

    The record is written to a temporary file that is then hard-linked to the lock name
    (an exclusive, atomic create: a run killed meanwhile leaves no half-written lock).
    """
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(record, sort_keys=True) + "\n", encoding="utf-8")
    try:
        os.link(tmp, path)
    except FileExistsError:
        return False
    finally:
        tmp.unlink(missing_ok=True)
    return True


def acquire_results_lock(folder: str | Path, checkout: str | Path, *, pid: int | None = None) -> str | None:
    """Take the lock of a results folder for this process.

    Parameters
    ----------
    folder : str or Path
        ``results/<name>`` (created if needed).
    checkout : str or Path
        The workflow's folder (recorded, named in messages).
    pid : int, optional
        Owner process id (default: this process).

    Returns
    -------
    str or None
        A message when a stale lock (dead owner on this host) was taken over.

    Raises
    ------
    ResultsLockedError
        Another live run holds the folder, or a run on another host does.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / LOCK_NAME
    pid = os.getpid() if pid is None else int(pid)
    host = socket.gethostname()
    record = {"pid": pid, "host": host, "checkout": str(Path(checkout).resolve()),
              "started": _dt.datetime.now(tz=_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"), "start_ticks": _start_ticks(pid)}
    note = None
    for _ in range(3):
        if _write_new(path, record):
            return note
        owner = lock_owner(path.parent)
        if owner is None:
            continue  # released in between: try again
        if owner.get("host") == host and owner.get("pid") == pid:
            return note  # ours already (onstart called twice)
        if not owner:
            raise ResultsLockedError(f"{path}: lock file without an owner record; if no run is writing {folder}, "
                                     "delete it and run again")
        if owner.get("host") != host:
            raise ResultsLockedError(
                f"{folder}: locked by a run on another host ({_describe(owner)}); its processes cannot be checked "
                f"from here. If that run is over, delete {path} and run again")
        if isinstance(owner.get("pid"), int) and _alive(owner["pid"], owner.get("start_ticks")):
            raise ResultsLockedError(
                f"{folder}: another run is writing this results folder ({_describe(owner)}); wait for it to "
                "finish (or stop it), then run again")
        note = (f"{folder}: took over the lock of a run that no longer runs ({_describe(owner)}); its unfinished "
                "jobs are run again")
        path.unlink(missing_ok=True)
    raise ResultsLockedError(f"{folder}: could not take {path} (another run took it at the same time)")


def release_results_lock(folder: str | Path, *, pid: int | None = None) -> bool:
    """Remove the lock of a results folder if this process holds it.

    Parameters
    ----------
    folder : str or Path
        ``results/<name>``.
    pid : int, optional
        Owner process id (default: this process).

    Returns
    -------
    bool
        True if a lock of ours was removed.
    """
    owner = lock_owner(folder)
    pid = os.getpid() if pid is None else int(pid)
    if owner and owner.get("pid") == pid and owner.get("host") == socket.gethostname():
        (Path(folder) / LOCK_NAME).unlink(missing_ok=True)
        return True
    return False
