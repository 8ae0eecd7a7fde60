"""The real records dronewind is tested and run on: a registry and the folder that holds them.

Each record is a folder of files (e.g. ``fluxpart_csat3_toa5/``) inside one *data folder*.
The registry (``data_registry.txt`` beside this module) lists every file with its size,
sha256, its download URL where an upstream copy with the same bytes exists, and its kind (data,
or a licence or notes file that is checked only when present);
:data:`RECORDS` gives each record's description, upstream source and licence.

The data folder is, in order of precedence:

1. the environment variable ``DRONEWIND_DATA`` (a folder that already holds the records, or
   the folder they are fetched into);
2. pooch's cache folder for dronewind (``pooch.os_cache("dronewind")``, e.g.
   ``~/.cache/dronewind`` on Linux).

Campaign manifests reach this folder with ``data_root: registry`` (:mod:`dronewind.manifest`).

From the command line::

    python -m dronewind.datasets list            # records, licences, present or not
    python -m dronewind.datasets fetch [NAME...] # download what has a URL, check every file
    python -m dronewind.datasets check [NAME...] # sizes and sha256 of the files present

Records under GPL-3.0 (``nmt_uas_sonic``, ``ardupilot_dataflash``) are read where they lie and
never copied into the project's repository.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
from dataclasses import dataclass
from functools import cache, lru_cache
from pathlib import Path

from dronewind.errors import InputError

__all__ = ["RECORDS", "ENV_VAR", "Record", "RegistryFile", "data_dir", "registry", "files_of",
           "is_present", "get_record", "check_record", "fetch"]

#: Environment variable naming the data folder.
ENV_VAR = "DRONEWIND_DATA"

#: The command that fetches the records (named by error and skip messages).
FETCH_COMMAND = "python -m dronewind.datasets fetch"

_REGISTRY_FILE = Path(__file__).with_name("data_registry.txt")


@dataclass(frozen=True)
class Record:
    """One real record: a folder of the data folder."""

    name: str
    description: str
    source: str
    licence: str
    licence_file: str
    copy: bool  # whether excerpts may be copied into the repository (tests/data)


@dataclass(frozen=True)
class RegistryFile:
    """One file of the registry."""

    path: str  # relative to the data folder, POSIX
    size: int
    sha256: str
    url: str | None
    needed: bool  # a data file (needed); False for licence and notes (checked when present)


#: The records, by folder name.
RECORDS: dict[str, Record] = {r.name: r for r in [
    Record("fluxpart_csat3_toa5",
           "Campbell CSAT3 sonic (and open-path gas analyser) on a tower over a crop, TOA5 at 20 Hz, "
           "two files of 15 min, 7 June 2012; heights.csv gives the measurement and canopy heights",
           "fluxpart test data, USDA-ARS (github.com/usda-ars-ussl/fluxpart, tests/data/)",
           "CC0-1.0 (U.S. government work)", "LICENSE", True),
    Record("ameriflux_gold_openpath",
           "AmeriFlux open-path 'gold' intercomparison files: Gill WindMaster Pro at 2 m over grass, "
           "10 Hz, 96 half-hours of two days (days 104 and 181); columns w, u, v (m/s), sonic "
           "temperature (degC), H2O and CO2 (V); conventions in the .doc notes",
           "AmeriFlux QA/QC laboratory, as distributed in SonicLib by Patrizia Favaron "
           "(github.com/patti-favaron/SonicLib, AmerifluxGoldFiles/G*.RAW, gzip-compressed here)",
           "MIT (SonicLib repository)", "LICENSE.SonicLib", True),
    Record("nmt_uas_sonic",
           "DJI M600 Pro multicopter with a rigidly mounted 3-D sonic, sonic and vehicle log (velocity "
           "east/north/up, attitude, position) merged at 5 Hz, 24 min, 19 April 2023",
           "New Mexico Tech UAS wind example (github.com/jfdoolster/nmt_uas_wind_direction, data/level0.csv)",
           "GPL-3.0", "LICENSE.md", False),
    Record("px4_ulog",
           "PX4 ULog sample logs (on the bench, not flying), for the ULog reader",
           "pyulog test data (github.com/PX4/pyulog, test/sample.ulg and test/sample_log_small.ulg)",
           "BSD-3-Clause", "LICENSE.md", True),
    Record("ardupilot_dataflash",
           "ArduCopter DataFlash log of a hovering multicopter at Finse, Norway, 28 March 2023, 163 s: "
           "attitude and set points, EKF velocity and position, GPS, barometer, the EKF's wind estimate",
           "github.com/noctiluc3nt/ec_analyze, fieldwork/drones/202303_finse/raw_drone/mission_planer/"
           "'2023-03-28 06-02-40.bin' (history before commit 5fa780e), renamed",
           "GPL-3.0", "LICENSE", False),
]}


def data_dir() -> Path:
    """The data folder: ``$DRONEWIND_DATA``, else pooch's cache folder for dronewind."""
    env = os.environ.get(ENV_VAR, "").strip()
    if env:
        return Path(env).expanduser().resolve()
    import pooch  # only where no folder is named (pooch is a dependency, imported when needed)

    return Path(pooch.os_cache("dronewind"))


@lru_cache(maxsize=1)
def registry() -> dict[str, RegistryFile]:
    """Every registered file by its path in the data folder (read from ``data_registry.txt``)."""
    files: dict[str, RegistryFile] = {}
    for lineno, line in enumerate(_REGISTRY_FILE.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        parts = line.split()
        if len(parts) != 5 or len(parts[2]) != 64 or not parts[1].isdigit() or parts[4] not in ("data", "doc"):
            raise InputError(f"{_REGISTRY_FILE}:{lineno}",
                             "expected 'path size sha256 url kind' (url '-' for none, kind data or doc)")
        path, size, sha, url, kind = parts
        files[path] = RegistryFile(path, int(size), sha, None if url == "-" else url, kind == "data")
    return files


def _record(name: str) -> Record:
    if name not in RECORDS:
        raise InputError(name, f"no such record; expected one of {', '.join(sorted(RECORDS))}")
    return RECORDS[name]


def files_of(name: str) -> list[RegistryFile]:
    """The registered files of record ``name``."""
    _record(name)
    return [f for p, f in registry().items() if p.split("/", 1)[0] == name]


def is_present(name: str, folder: Path | None = None) -> bool:
    """Whether every data file of record ``name`` is in the data folder (sizes checked, not hashes)."""
    root = data_dir() if folder is None else Path(folder)
    return all((root / f.path).is_file() and (root / f.path).stat().st_size == f.size
               for f in files_of(name) if f.needed)


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@cache
def _verified(name: str, path: Path, size: int, sha: str, mtime_ns: int) -> None:
    """Check one file of record ``name`` against the registry (remembered per process for an unchanged file)."""
    got_size = path.stat().st_size
    if got_size != size:
        raise InputError(path, f"file of record {name!r}: size {got_size} bytes, expected {size} (registry of "
                         f"dronewind.datasets); replace the file ({FETCH_COMMAND} {name})")
    got = _sha256(path)
    if got != sha:
        raise InputError(path, f"file of record {name!r}: sha256 {got}, expected {sha} (registry of "
                         f"dronewind.datasets); replace the file ({FETCH_COMMAND} {name})")


def check_record(name: str, folder: Path | None = None) -> Path:
    """Check the files of record ``name`` (data files present; size and sha256 of every file present).

    Returns the record's folder.

    Raises
    ------
    FileNotFoundError
        A data file is missing; the message names the file, the data folder and the fetch command.
    InputError
        A file's size or sha256 differs from the registry (names the file, expected and got).
    """
    root = data_dir() if folder is None else Path(folder)
    for f in files_of(name):
        path = root / f.path
        if not path.is_file() and not f.needed:
            continue
        if not path.is_file():
            raise FileNotFoundError(
                f"{path}: file of record {name!r} missing from the data folder {root} "
                f"(set {ENV_VAR} to the folder holding the records, or run `{FETCH_COMMAND} {name}`)")
        _verified(name, path, f.size, f.sha256, path.stat().st_mtime_ns)
    return root / name


def get_record(name: str) -> Path:
    """The folder of record ``name`` in the data folder, every file checked against the registry."""
    return check_record(_record(name).name)


def fetch(names: list[str] | None = None, folder: Path | None = None) -> list[Path]:
    """Download the missing files of the given records (all by default) and check every file.

    pooch downloads each missing file that has a URL and checks its sha256. Data files without
    a URL must be placed in the data folder by hand: the error lists them with the record's
    source and licence. Returns the records' folders.
    """
    import pooch

    root = data_dir() if folder is None else Path(folder)
    out = []
    for name in names or sorted(RECORDS):
        rec = _record(name)
        by_hand = []
        for f in files_of(name):
            path = root / f.path
            if path.is_file():
                continue
            if f.url is not None:
                pooch.retrieve(f.url, known_hash=f"sha256:{f.sha256}", fname=path.name,
                               path=path.parent, progressbar=False)
            elif f.needed:
                by_hand.append(path)
        if by_hand:
            raise FileNotFoundError(
                f"record {name!r}: {len(by_hand)} file(s) without a download URL must be placed by hand "
                f"({', '.join(str(p) for p in by_hand[:3])}{' ...' if len(by_hand) > 3 else ''}); "
                f"source: {rec.source}; licence: {rec.licence}")
        out.append(check_record(name, root))
    return out


def main(argv: list[str] | None = None) -> int:
    """Command line: ``list``, ``fetch [NAME...]``, ``check [NAME...]``."""
    parser = argparse.ArgumentParser(prog="python -m dronewind.datasets", description=__doc__.split("\n")[0])
    parser.add_argument("command", choices=["list", "fetch", "check"])
    parser.add_argument("names", nargs="*", help="records (default: all)")
    args = parser.parse_args(argv)
    root = data_dir()
    if args.command == "list":
        print(f"data folder: {root} ({ENV_VAR} {'set' if os.environ.get(ENV_VAR) else 'unset: pooch cache'})")
        for rec in RECORDS.values():
            state = "present" if is_present(rec.name, root) else "absent"
            size = sum(f.size for f in files_of(rec.name)) / 1e6
            print(f"{rec.name:25s} {state:8s} {size:6.1f} MB  {rec.licence}  [{rec.source}]")
        return 0
    status = 0
    for name in args.names or sorted(RECORDS):
        try:
            if args.command == "fetch":
                fetch([name], root)
            else:
                check_record(name, root)
            print(f"{name}: ok ({root / name})")
        except (OSError, InputError, ValueError) as exc:
            print(f"{name}: {exc}", file=sys.stderr)
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
