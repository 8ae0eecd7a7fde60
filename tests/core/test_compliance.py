"""The compliance checker's remembered metadata scans (dronewind.core.compliance): same reports, copies, per file."""

from __future__ import annotations

import importlib
import types

import numpy as np
import xarray as xr

from dronewind.core.cf import check_compliance_files
from dronewind.core.compliance import REMEMBERED_SCANS, ScanMemo, remember_scans, report_sections
from tests.core.test_cf import write


def test_memo_hands_each_caller_its_own_copy_and_forgets_between_files():
    calls = []

    def scan(nc, name=None):
        calls.append((nc, name))
        return {"axes": [name or "all"]}

    memo, nc = ScanMemo(), object()
    first = memo.call("scan", scan, nc, ())
    first["axes"].append("changed by a caller")
    assert memo.call("scan", scan, nc, ()) == {"axes": ["all"]}  # what the next caller sees is untouched
    assert memo.call("scan", scan, nc, ("u",)) == {"axes": ["u"]}  # other arguments, another answer
    assert (memo.hits, memo.misses, len(calls)) == (1, 2, 2)
    memo.clear()
    other = object()
    memo.call("scan", scan, other, ())
    assert len(calls) == 3 and calls[-1] == (other, None)
    memo.call("scan", scan, other, (["unhashable"],))  # cannot be a key: scanned every time
    memo.call("scan", scan, other, (["unhashable"],))
    assert len(calls) == 5


def test_only_the_named_scans_of_the_module_are_wrapped():
    util = types.ModuleType("fake_util")
    counted = {"n": 0}

    def get_axis_variables(nc):
        counted["n"] += 1
        return ["time"]

    util.get_axis_variables = get_axis_variables
    util.untouched = len
    memo = remember_scans(util, ("get_axis_variables", "not_in_this_version", "untouched_not_named"))
    assert util.get_axis_variables.__name__ == "get_axis_variables" and util.untouched is len
    assert not hasattr(util, "not_in_this_version")
    nc = object()
    assert util.get_axis_variables(nc) == util.get_axis_variables(nc) == ["time"]
    assert counted["n"] == 1 and memo.hits == 1
    assert set(REMEMBERED_SCANS) <= set(dir(importlib.import_module("compliance_checker.cf.util"))), (
        "a remembered scan is missing from the installed checker")


def test_remembered_scans_give_the_checker_s_own_reports(tmp_path):
    """A product that passes, one with groups and a bare file that fails: the same verdicts and
    the same report, suite by suite, as the checker as installed."""
    freq = np.linspace(0.01, 4, 50)
    spectra = xr.Dataset({"psd_u": ("frequency", freq ** (-5 / 3), {"units": "m2 s-1", "long_name": "PSD of u"})},
                         coords={"frequency": ("frequency", freq, {"units": "Hz", "long_name": "frequency"})})
    files = [write(tmp_path / "mast.nc"), write(tmp_path / "spec.nc", groups={"spectra": spectra})]
    bare = tmp_path / "bare.nc"
    xr.Dataset({"x": ("t", np.arange(3.0)), "y": ("t", np.ones(3), {"units": "m"})}).to_netcdf(bare)
    files.append(bare)
    remembered = check_compliance_files(files)
    plain = check_compliance_files(files, remember=False)
    assert [remembered[p][0] for p in files] == [plain[p][0] for p in files] == [True, True, False]
    for path in files:
        sections = report_sections(remembered[path][1])
        assert sum("IOOS Compliance Checker Report" in s for s in sections) == 2, sections  # cf and acdd
        assert sections == report_sections(plain[path][1]), path
