#!/usr/bin/env python
"""Compare two results folders of the same campaign: data, attributes and tables.

Used to show that a change of code layout changed no output. For every NetCDF file found
under both folders, every variable (including group variables) must have the same dtype,
shape, values (NaN equal to NaN) and attributes, and every global attribute must be equal,
except the provenance attributes that record when, where and with which configuration a
file was made (listed in ``PROVENANCE``). CSV and Markdown tables must be byte-identical;
JSON files are compared after parsing, ignoring provenance keys.

Examples
--------
    .venv/bin/python benchmarks/compare_results.py /work/before/results/mosai2023 results/mosai2023
    .venv/bin/python benchmarks/compare_results.py A B --json comparison.json
    .venv/bin/python benchmarks/compare_results.py A B --summary --json summary.json
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np

#: Global attributes that record provenance (time, configuration, software), not data.
PROVENANCE = {
    "history", "date_created", "date_modified", "date_issued", "date_metadata_modified",
    "config_hash", "config_sha256", "input_checksums", "software_version", "dronewind_version", "product_version",
}
#: Keys of JSON records that are provenance.
JSON_PROVENANCE = {"config_hash", "created", "date_created", "checksums", "input_checksums", "config",
                   "software_version", "version"}


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    if isinstance(a, float) and isinstance(b, float) and np.isnan(a) and np.isnan(b):
        return True
    return bool(a == b) and type(a) is type(b)


def _compare_group(ga: netCDF4.Group, gb: netCDF4.Group, where: str, out: list[str]) -> int:
    n = 0
    for name in sorted(set(ga.ncattrs()) | set(gb.ncattrs())):
        if name in PROVENANCE:
            continue
        if name not in ga.ncattrs() or name not in gb.ncattrs():
            out.append(f"{where}: global attribute {name!r} only in one file")
        elif not _equal(ga.getncattr(name), gb.getncattr(name)):
            out.append(f"{where}: global attribute {name!r}: {ga.getncattr(name)!r} != {gb.getncattr(name)!r}")
    for name in sorted(set(ga.variables) | set(gb.variables)):
        if name not in ga.variables or name not in gb.variables:
            out.append(f"{where}: variable {name!r} only in one file")
            continue
        va, vb = ga.variables[name], gb.variables[name]
        va.set_auto_maskandscale(False)
        vb.set_auto_maskandscale(False)
        n += 1
        if va.dimensions != vb.dimensions:
            out.append(f"{where}:{name}: dimensions {va.dimensions} != {vb.dimensions}")
        if not _equal(np.asarray(va[...]), np.asarray(vb[...])):
            a, b = np.asarray(va[...]), np.asarray(vb[...])
            detail = f"dtype {a.dtype}/{b.dtype} shape {a.shape}/{b.shape}"
            if a.shape == b.shape and a.dtype.kind in "fi" and b.dtype.kind in "fi":
                with np.errstate(invalid="ignore"):
                    detail += f", max |diff| {np.nanmax(np.abs(a.astype(float) - b.astype(float)), initial=0.0):.3g}"
            out.append(f"{where}:{name}: values differ ({detail})")
        for attr in sorted(set(va.ncattrs()) | set(vb.ncattrs())):
            if attr not in va.ncattrs() or attr not in vb.ncattrs():
                out.append(f"{where}:{name}: attribute {attr!r} only in one file")
            elif not _equal(va.getncattr(attr), vb.getncattr(attr)):
                out.append(f"{where}:{name}: attribute {attr!r}: {va.getncattr(attr)!r} != {vb.getncattr(attr)!r}")
    for gname in sorted(set(ga.groups) | set(gb.groups)):
        if gname not in ga.groups or gname not in gb.groups:
            out.append(f"{where}: group {gname!r} only in one file")
            continue
        n += _compare_group(ga.groups[gname], gb.groups[gname], f"{where}/{gname}", out)
    return n


def _strip(node: Any) -> Any:
    if isinstance(node, dict):
        return {k: _strip(v) for k, v in node.items() if k not in JSON_PROVENANCE}
    if isinstance(node, list):
        return [_strip(v) for v in node]
    return node


def compare(a: Path, b: Path) -> dict[str, Any]:
    """Compare results folders ``a`` and ``b``; return counts and the list of differences."""
    diffs: list[str] = []
    counts = {"netcdf_files": 0, "variables": 0, "tables": 0, "json": 0}
    files_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file() and "logs" not in p.parts
               and "benchmarks" not in p.parts}
    files_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file() and "logs" not in p.parts
               and "benchmarks" not in p.parts}
    for rel in sorted(files_a ^ files_b):
        diffs.append(f"{rel}: only in {'A' if rel in files_a else 'B'}")
    for rel in sorted(files_a & files_b):
        pa, pb = a / rel, b / rel
        if rel.suffix == ".nc":
            counts["netcdf_files"] += 1
            with netCDF4.Dataset(pa) as da, netCDF4.Dataset(pb) as db:
                counts["variables"] += _compare_group(da, db, str(rel), diffs)
        elif rel.suffix in {".csv", ".md", ".tex"} and "L0" not in rel.parts:
            counts["tables"] += 1
            if pa.read_bytes() != pb.read_bytes():
                diffs.append(f"{rel}: bytes differ")
        elif rel.suffix == ".json":
            counts["json"] += 1
            if _strip(json.loads(pa.read_text())) != _strip(json.loads(pb.read_text())):
                diffs.append(f"{rel}: content differs (provenance keys ignored)")
        elif "L0" in rel.parts:
            counts.setdefault("L0_files", 0)
            counts["L0_files"] += 1
            if pa.read_bytes() != pb.read_bytes():
                diffs.append(f"{rel}: L0 bytes differ")
    return {"a": str(a), "b": str(b), "counts": counts, "n_differences": len(diffs), "differences": diffs}


def summarise(differences: list[str]) -> dict[str, Any]:
    """The differences grouped over flights and UAVs (ids replaced by ``*``): how many, and the
    largest ``max |diff|`` where values differ; path-only attributes (``source_file``) counted apart."""
    groups: dict[str, dict[str, Any]] = {}
    for line in differences:
        key = re.sub(r"(?<![A-Za-z0-9])[sfqm]\d\d(?![0-9])", "*", line.split(": ", 1)[0])
        if "'source_file'" in line:
            key = "source_file attributes (the results folder's path)"
        entry = groups.setdefault(key, {"n": 0, "max_abs_diff": None})
        entry["n"] += 1
        found = re.search(r"max \|diff\| ([-+0-9.eE]+|nan|inf)", line)
        if found:
            value = float(found.group(1))
            entry["max_abs_diff"] = value if entry["max_abs_diff"] is None else max(entry["max_abs_diff"], value)
    return dict(sorted(groups.items()))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("a", type=Path, help="first results folder (results/<campaign>)")
    parser.add_argument("b", type=Path, help="second results folder")
    parser.add_argument("--json", type=Path, help="write the comparison as JSON here")
    parser.add_argument("--summary", action="store_true",
                        help="in the JSON, the differences grouped over flights (summarise) instead of each line")
    args = parser.parse_args(argv)
    result = compare(args.a, args.b)
    if args.summary:
        result["summary"] = summarise(result.pop("differences"))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result["counts"]), f"{result['n_differences']} differences")
    lines = [f"{k}: {v}" for k, v in result["summary"].items()] if args.summary else result["differences"]
    for line in lines[:200]:
        print("  " + line)
    return 0 if result["n_differences"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
