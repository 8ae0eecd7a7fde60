"""What several benchmarks share: the commit they ran, CPU time, their result as JSON (printed and in ``--out``),
the command line of a benchmark on a finished run."""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
#: The embedded default campaign's manifest.
DEFAULT_CAMPAIGN = REPO / "config" / "campaigns" / "mosai2023.yaml"


def git_commit(folder: Path = REPO) -> str:
    """The commit of the checkout that holds ``folder`` (this repository by default), or "unknown".

    Pass the folder of the imported package (``Path(dronewind.__file__).parent``) to record the
    source tree a benchmark ran when ``PYTHONPATH`` points at another worktree."""
    proc = subprocess.run(["git", "rev-parse", "HEAD"], cwd=folder, capture_output=True, text=True, check=False)
    return proc.stdout.strip() or "unknown"


#: Folder of the current result of each study (``<study>.json``, one file per study).
RESULTS = REPO / "benchmarks" / "results"


def command_line() -> str:
    """This process's command line, as it would be typed from the repository root."""
    import shlex
    import sys

    return shlex.join(["python", *sys.argv])


def machine() -> dict[str, Any]:
    """The processor model, its number of cores and the interpreter: where a benchmark ran.

    Returns
    -------
    dict
        ``cpu`` (``model name``, CPU family and model of ``/proc/cpuinfo``; the platform's
        processor name elsewhere), ``cores`` (usable by this process) and ``python``.
    """
    import os
    import platform

    fields: dict[str, str] = {}
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            key, _, value = line.partition(":")
            fields.setdefault(key.strip(), value.strip())
    cpu = fields.get("model name") or platform.processor() or platform.machine()
    if "cpu family" in fields:
        cpu += f" (family {fields['cpu family']}, model {fields.get('model', '?')})"
    return {"cpu": cpu, "cores": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
            "python": platform.python_version()}


def reference_workload_s(repeats: int = 3) -> float:
    """CPU seconds of a fixed single-threaded workload, the least of ``repeats``.

    The workload: 20 seeded series of 2^20 numbers, each sorted, Fourier-transformed and
    filtered by a moving median (bottleneck), as the chain and the forward runs do. The same
    code's CPU time moves with the machine's state (on the 2-core test machine the default
    campaign's jobs took 319 to 368 CPU-s for the same code, this number 0.389 to 0.457 s beside
    them): a run's times compare with another's in proportion to this number.
    """
    import time

    import bottleneck as bn
    import numpy as np

    data = np.random.default_rng(0).standard_normal((20, 2**20))
    best = float("inf")
    for _ in range(repeats):
        c0 = time.process_time()
        for row in data:
            np.sort(row)
            np.fft.rfft(row)
            bn.move_median(row[: 2**16], window=201)
        best = min(best, time.process_time() - c0)
    return round(best, 3)


def print_and_write(result: Any, out: Path | None, indent: int = 1) -> None:
    """Print ``result`` as JSON and write the same text to ``out`` (its folder created) when given.

    A dictionary result gets the command that made it (``command``, this process's arguments)
    and the machine it was measured on (:func:`machine`): CPU seconds are only comparable on the
    same processor.

    Parameters
    ----------
    result : JSON-serialisable
        The benchmark's result.
    out : Path, optional
        File to write (``--out``).
    indent : int
        JSON indentation.
    """
    if isinstance(result, dict) and "command" not in result:
        result = {"command": command_line(), **result}
    if isinstance(result, dict) and "machine" not in result:
        result = {**result, "machine": machine()}
    text = json.dumps(result, indent=indent)
    print(text)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text + "\n")


def default_forward_setup() -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """The default campaign's manifest content, the default configuration and its forward-chain settings.

    Returns
    -------
    data : dict
        Manifest content of ``config/campaigns/mosai2023.yaml``.
    config : dict
        :func:`dronewind.manifest.default_config`.
    processing : dict
        Its ``processing`` settings of :data:`dronewind.diagnose.probes.CHAIN_SETTINGS`.
    """
    from dronewind.diagnose.probes import CHAIN_SETTINGS
    from dronewind.manifest import default_config, load_campaign

    config = default_config()
    data = load_campaign(DEFAULT_CAMPAIGN).data
    return data, config, {key: config["processing"][key] for key in CHAIN_SETTINGS}


def cpu_s_with_children() -> float:
    """CPU time [s] (user + system) of this process and of the children it has waited for."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def finished_run_parser(doc: str | None, results_help: str = "a finished run's results/<campaign> folder",
                        default_out: Path | None = None) -> argparse.ArgumentParser:
    """Command line of a benchmark on a finished run: the results folder (positional) and ``--out``.

    Parameters
    ----------
    doc : str
        The benchmark's module docstring (its ``--help`` text, examples kept as written).
    results_help : str
        Help of the ``results`` argument.

    Returns
    -------
    argparse.ArgumentParser
        Add the benchmark's own options, then ``parse_args()``.
    """
    parser = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("results", type=Path, help=results_help)
    parser.add_argument("--out", type=Path, default=default_out,
                        help=f"JSON file to write (default: {default_out})" if default_out else "JSON file to write")
    return parser
