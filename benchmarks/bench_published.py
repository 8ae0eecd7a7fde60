"""CPU time of the published-numbers forward runs, sample by sample, in one process (any code version).

Runs :func:`dronewind.steps.published.published_forward` for every stationary sample of the
default published file (``config/published/ghirardelli2025_samurai_s.yaml``) with the default
configuration, then :func:`dronewind.steps.published.published_diagnosis` on them, and reports
the CPU seconds of each step (``time.process_time``, this process only: the forward runs are
in-process). With ``PYTHONPATH`` set to an older source tree it measures that version, so a
before/after pair runs the same script::

    git worktree add /tmp/base HEAD~1
    PYTHONPATH=/tmp/base/src .venv/bin/python benchmarks/bench_published.py --work /tmp/pub_before \\
        --out /tmp/pub_before.json
    PYTHONPATH=src .venv/bin/python benchmarks/bench_published.py --work /tmp/pub_after \\
        --out benchmarks/results/published_cpu.json
    .venv/bin/python benchmarks/compare_results.py /tmp/pub_before /tmp/pub_after --summary

The forward JSON files and ``diagnosis.json`` are written to ``--work``. With ``--forward`` (a
finished run's ``published/forward`` folder) only the fit runs, ``--repeat`` times, on those
files::

    PYTHONPATH=src .venv/bin/python benchmarks/bench_published.py --forward results/mosai2023/published/forward \
        --work /tmp/pub_fit --repeat 3 --out /tmp/fit.json
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from bench_common import DEFAULT_CAMPAIGN, REPO, git_commit, print_and_write
from dronewind.diagnose import forward, probes
from dronewind.diagnose.published import load_published
from dronewind.manifest import default_config, load_campaign, payload_flight_manifest
from dronewind.steps.published import published_diagnosis, published_forward

PUBLISHED = REPO / "config" / "published" / "ghirardelli2025_samurai_s.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work", type=Path, required=True, help="folder for the forward runs and diagnosis.json")
    parser.add_argument("--out", type=Path, help="JSON file for the timings")
    parser.add_argument("--forward", type=Path,
                        help="a finished run's published/forward folder: time only the fit on its files")
    parser.add_argument("--repeat", type=int, default=1, help="repetitions of the fit (with --forward)")
    args = parser.parse_args()
    if args.forward is not None:
        fit_only(args.forward, args.work, args.repeat, args.out)
        return
    config = default_config()
    processing = {key: config["processing"][key] for key in probes.CHAIN_SETTINGS}
    seeds = config["diagnosis"]["seeds"]
    data = load_campaign(DEFAULT_CAMPAIGN).data
    samples = load_published(PUBLISHED)["stationary_flights"]
    (args.work / "forward").mkdir(parents=True, exist_ok=True)
    cpu: dict[str, float] = {}
    files = []
    for flight in samples:
        t0 = time.process_time()
        files.append(published_forward(PUBLISHED, args.work / "forward" / f"{flight}.json",
                                       campaign=payload_flight_manifest(data, flight, atmosphere=True),
                                       flight_id=flight, processing=processing, seeds=seeds))
        cpu[flight] = round(time.process_time() - t0, 3)
    t0 = time.process_time()
    published_diagnosis(PUBLISHED, files, args.work / "diagnosis.json", alpha=config["diagnosis"]["alpha"],
                        max_causes=config["diagnosis"]["max_causes"])
    result = {"commit": git_commit(Path(forward.__file__).parent), "samples": samples, "seeds": list(seeds),
              "forward_cpu_s": cpu, "forward_cpu_s_total": round(sum(cpu.values()), 2),
              "diagnosis_cpu_s": round(time.process_time() - t0, 3)}
    print_and_write(result, args.out)


def fit_only(forward_dir: Path, work: Path, repeat: int, out: Path | None) -> None:
    """CPU seconds of :func:`published_diagnosis` alone on a finished run's forward files."""
    config = default_config()
    files = sorted(forward_dir.glob("*.json"))
    work.mkdir(parents=True, exist_ok=True)
    cpu = []
    for _ in range(repeat):
        t0 = time.process_time()
        published_diagnosis(PUBLISHED, files, work / "diagnosis.json", alpha=config["diagnosis"]["alpha"],
                            max_causes=config["diagnosis"]["max_causes"])
        cpu.append(round(time.process_time() - t0, 3))
    print_and_write({"commit": git_commit(Path(forward.__file__).parent), "forward": str(forward_dir),
                     "samples": [f.stem for f in files], "diagnosis_cpu_s": cpu}, out)


if __name__ == "__main__":
    main()
