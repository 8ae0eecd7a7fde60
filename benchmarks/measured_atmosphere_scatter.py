"""Seed scatter of the measured-atmosphere forward model against the scatter of independent realisations.

N virtual flights of one campaign's conditions (different campaign seeds: independent true
atmospheres), each processed as measured and forward-run with K baseline seeds of its own,
the seeds resampling the mast record's spectral sampling error as the simulator does; per
feature the ratio R of the seed variance, times 1 + 1/K, to the variance of measured minus predicted
(1 when the diagnosis' errors are right) and its 95 % interval under R = 1
(``dronewind.diagnose.atmosphere_scatter``)::

    cd benchmarks && PYTHONPATH=../src:. nice ../.venv/bin/python measured_atmosphere_scatter.py \\
        --realisations 100 --seeds 4 --out results/measured_atmosphere_scatter.json

(about 280 CPU-s; 48 realisations by default)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from bench_common import git_commit, machine, print_and_write
from dronewind.diagnose import atmosphere_scatter as sc

FEATURES = ("ln_sigma_ratio_u", "ln_sigma_ratio_v", "ln_sigma_ratio_w", "ln_speed_ratio", "dir_diff_deg",
            "tilt_diff_deg", "sw_su_drone", "ln_pendulum_w", "ln_hf_u", "ln_hf_w")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--realisations", type=int, default=48, help="N true realisations (default 48)")
    parser.add_argument("--seeds", type=int, default=4, help="K baseline seeds per realisation (default 4)")
    parser.add_argument("--hover-min", type=float, default=12.0, help="hover length [min] (default 12)")
    parser.add_argument("--speed", type=float, default=5.5, help="mean wind speed [m/s] (default 5.5)")
    parser.add_argument("--out", type=Path,
        default=Path(__file__).resolve().parent / "results" / "measured_atmosphere_scatter.json",
        help="JSON file to write")
    args = parser.parse_args()
    start = time.process_time()
    out = {"command": "cd benchmarks && PYTHONPATH=../src:. nice ../.venv/bin/python measured_atmosphere_scatter.py "
                      + " ".join(sys.argv[1:]),
           "commit": git_commit(Path(sc.__file__).parent), "machine": machine(),
           "realisations": args.realisations, "seeds_per_realisation": args.seeds, "hover_min": args.hover_min,
           "speed_ms": args.speed, "interval_95": list(sc.ratio_interval(args.realisations, args.seeds)),
           "ratio": {}, "realisation_variance": {}, "seed_variance": {}}
    res = sc.realisation_scatter(args.realisations, args.seeds, FEATURES, args.hover_min, args.speed)
    for key in ("ratio", "realisation_variance", "seed_variance"):
        out[key]["resampled_spectra"] = {f: round(float(x), 6) for f, x in zip(FEATURES, res[key], strict=True)}
    out["cpu_s"] = round(time.process_time() - start, 1)
    print_and_write(out, args.out)


if __name__ == "__main__":
    main()
