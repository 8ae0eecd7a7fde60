r"""The IOOS compliance checker on many files in one process, its repeated metadata scans remembered per file.

Run as ``python -m dronewind.core.compliance TESTS CRITERIA FILE...`` by
:func:`dronewind.core.cf.check_compliance_files`: each file is checked with the call the
``compliance-checker`` command makes for it (``ComplianceChecker.run_checker``, the
checker's own API), its text report captured; the results go to standard output as JSON
``{path: [passed, report]}``. A file the checker cannot open fails with the error as its
report, as the command exits non-zero on it.

Why the scans are remembered
----------------------------
The checker's CF suite answers questions about a file's structure (which variables are
auxiliary coordinates, which are geophysical, which are the latitude, longitude, vertical
and time axes, the feature type of a variable) from scratch every time a check asks: on a
product of this workflow, ``get_auxiliary_coordinate_variables`` alone runs hundreds of
times per file, each a scan over every variable and its attributes; remembered, they take
the checker about half its time per file. They are pure functions of the open, read-only
file (and a variable name), so :func:`remember_scans` wraps them in the checker's utility module with a
memo that lives for one file (:meth:`ScanMemo.clear` before the next) and hands every caller
its own deep copy of the answer, so no check can change what another one sees. Every check
still runs and reports: the reports of the NetCDF files of a default run are the same with
and without the memo, apart from their time stamps.

With ``--plain`` the checker runs without the memo. The checker orders some messages of a
report by iterating sets of variable names, so the order changes with Python's string
hashing from one process to the next; :func:`dronewind.core.cf.check_compliance_files`
starts this process with ``PYTHONHASHSEED=0``, which makes the reports the same in every
run (the verdicts never depended on it).
"""

from __future__ import annotations

import contextlib
import copy
import functools
import io
import json
import re
import sys
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import Any

__all__ = ["REMEMBERED_SCANS", "ScanMemo", "remember_scans", "check_files", "report_sections", "main"]

#: The checker's CF utilities (``compliance_checker.cf.util``) that scan a whole file's
#: metadata and are called many times per file with the same arguments: ``(nc)`` or
#: ``(nc, variable_name)``. Each answers with a list, a dict, a string or a bool, whose copy
#: iterates as the original does (``get_time_variables``, which answers with a set, is left
#: out: a copied set may iterate in another order, and the checker prints some messages in
#: the order it iterates them).
REMEMBERED_SCANS: tuple[str, ...] = (
    "get_auxiliary_coordinate_variables",
    "get_coordinate_variables",
    "get_geophysical_variables",
    "is_geophysical",
    "get_z_variables",
    "get_axis_variables",
    "get_latitude_variables",
    "get_longitude_variables",
    "get_forecast_metadata_variables",
    "coordinate_dimension_matrix",
    "guess_feature_type",
)


class ScanMemo:
    """Answers of the wrapped scans for the file being checked.

    Keys are the scan's name, the identity of the open file and the other arguments; each
    entry keeps its file object alive, so that identity cannot be reused by another object
    while the entry exists. :meth:`clear` before each file.
    """

    def __init__(self) -> None:
        self._store: dict[tuple[Any, ...], tuple[Any, Any]] = {}
        self.hits = 0
        self.misses = 0

    def clear(self) -> None:
        """Forget every answer (the next file)."""
        self._store.clear()

    def call(self, name: str, scan: Callable[..., Any], nc: Any, args: tuple[Any, ...]) -> Any:
        """``scan(nc, *args)``, remembered; a deep copy of the answer for every caller."""
        key = (name, id(nc), args)
        try:
            entry = self._store.get(key)
        except TypeError:  # an argument that cannot be a key: not remembered
            return scan(nc, *args)
        if entry is None:
            self.misses += 1
            entry = (nc, scan(nc, *args))
            self._store[key] = entry
        else:
            self.hits += 1
        return copy.deepcopy(entry[1])


def remember_scans(util: ModuleType, names: Sequence[str] = REMEMBERED_SCANS) -> ScanMemo:
    """Wrap the named functions of the checker's utility module with one memo.

    The checker's suites call them through the module (``cfutil.<name>``) and the module's
    own functions call each other by their global names, so replacing the module attribute
    reaches every caller. Names the installed checker does not have are left alone.

    Parameters
    ----------
    util : module
        ``compliance_checker.cf.util``.
    names : sequence of str
        Functions to wrap.

    Returns
    -------
    ScanMemo
        The memo; clear it before each file.
    """
    memo = ScanMemo()
    for name in names:
        scan = getattr(util, name, None)
        if not callable(scan):
            continue

        def remembered(nc: Any, *args: Any, _name: str = name, _scan: Callable[..., Any] = scan) -> Any:
            return memo.call(_name, _scan, nc, args)

        setattr(util, name, functools.wraps(scan)(remembered))
    return memo


def check_files(tests: Sequence[str], criteria: str, paths: Sequence[str],
                memo: ScanMemo | None = None) -> dict[str, list[Any]]:
    """Check each file as ``compliance-checker --test=... --criteria=...`` checks it alone.

    Parameters
    ----------
    tests : sequence of str
        Checker suites, e.g. ``("cf:1.11", "acdd:1.3")``.
    criteria : str
        ``strict``, ``normal`` or ``lenient``.
    paths : sequence of str
        NetCDF files.
    memo : ScanMemo, optional
        The memo of :func:`remember_scans`, cleared before each file.

    Returns
    -------
    dict
        ``{path: [passed, report]}``.
    """
    from compliance_checker.runner import ComplianceChecker

    out: dict[str, list[Any]] = {}
    for path in paths:
        if memo is not None:
            memo.clear()
        buf = io.StringIO()
        try:
            with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
                passed, errors = ComplianceChecker.run_checker([path], list(tests), 0, criteria, output_filename="-",
                                                               output_format=["text"])
            out[path] = [bool(passed) and not errors, buf.getvalue()]
        except Exception as exc:  # a file the checker cannot open fails, as the command exits non-zero on it
            out[path] = [False, buf.getvalue() + f"compliance checker error: {type(exc).__name__}: {exc}"]
    if memo is not None:
        memo.clear()
    return out


#: Where each suite's section of a text report starts, and the report's time stamp.
_SECTION = re.compile(r"\n(?=-{80}\n\s+IOOS Compliance Checker Report)")
_STAMP = re.compile(r"Report generated \S+")


def report_sections(report: str) -> list[str]:
    """A text report's suite sections, sorted, without the time stamps.

    The checker prints its suites (``cf:1.11``, ``acdd:1.3``) in an order that varies between
    processes unless the hash seed is fixed (:func:`dronewind.core.cf.check_compliance_files`
    fixes it) and stamps each section with the time; two reports say the same when their
    sections do.

    Parameters
    ----------
    report : str
        Text report of :func:`check_files`.

    Returns
    -------
    list of str
        The sections, stripped and sorted.
    """
    return sorted(filter(None, (s.strip() for s in _SECTION.split(_STAMP.sub("Report generated", report)))))


def main(argv: Sequence[str] | None = None) -> None:
    """Command line: check NetCDF files, the JSON result ``{path: [passed, report]}`` on standard output.

    Whatever the checker prints goes into each file's report.
    """
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m dronewind.core.compliance", description=__doc__.split("\n\n")[0],
        epilog="example:\n  python -m dronewind.core.compliance cf:1.11,acdd:1.3 normal "
               "results/mosai2023/netcdf/L4/*.nc", formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plain", action="store_true", help="run the checker as installed (no remembered scans)")
    parser.add_argument("tests", help="checker suites, comma separated (cf:1.11,acdd:1.3)")
    parser.add_argument("criteria", choices=["strict", "normal", "lenient"])
    parser.add_argument("files", nargs="*", help="NetCDF files")
    args = parser.parse_args(argv)
    import compliance_checker.cf.util as cfutil
    from compliance_checker.runner import CheckSuite

    CheckSuite().load_all_available_checkers()
    memo = None if args.plain else remember_scans(cfutil)
    results = check_files(args.tests.split(","), args.criteria, args.files, memo)
    json.dump(results, sys.stdout)


if __name__ == "__main__":
    main()
