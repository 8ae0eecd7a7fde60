"""Where one flight's forward runs spend their time: a profile, on a finished default run (any code version).

Runs :func:`dronewind.steps.diagnosis.forward_probes` (the ``diagnose_forward`` job) for one
flight under :mod:`cProfile` and reports the profiled total, the cumulative seconds and calls
of the functions named (``--functions``, matched against the profile's function names; of
namesakes the outermost) and,
where this code version remembers designs per setting, how often each was made and reused
(``functools.lru_cache`` statistics). Profiled seconds include the profiler's own cost, so
they are shares of the flight's work, not its CPU time (``bench_forward_flight.py``). With
``PYTHONPATH`` set to an older tree it profiles that version::

    PYTHONPATH=/tmp/old/src .venv/bin/python benchmarks/profile_forward_flight.py results/mosai2023 s02 \\
        --out /tmp/a.json
    PYTHONPATH=src .venv/bin/python benchmarks/profile_forward_flight.py results/mosai2023 s02 --out /tmp/b.json
"""

from __future__ import annotations

import cProfile
import pstats
import tempfile
from pathlib import Path

from bench_common import default_forward_setup, finished_run_parser, git_commit, print_and_write
from dronewind.manifest import payload_flight_manifest
from dronewind.steps import diagnosis as steps

#: Functions reported by default: the designs and bookkeeping session 26 changed, and the largest
#: single costs left (moving medians, FFTs, spline evaluations).
FUNCTIONS = ("butter", "design_antialias_fir", "cholesky", "coherence", "digest", "atmosphere_digest",
             "duplicated", "_interp_finite", "_ins_truth", "_sonic_sensor_frame", "move_median", "_raw_fft",
             "_evaluate", "forward_probes")
#: Designs remembered per setting (module, function), reported when this version has them.
REMEMBERED = (("dronewind.simulate.payload_motion", "_butter_sos"), ("dronewind.compare.align", "_antialias_taps"),
              ("dronewind.simulate.spectral_model", "_coherence_factor"))


def main() -> None:
    parser = finished_run_parser(__doc__, "a finished default run's results/<campaign> folder")
    parser.add_argument("flight", help="payload flight id")
    parser.add_argument("--functions", nargs="+", default=list(FUNCTIONS), help="function names to report")
    args = parser.parse_args()
    import importlib

    data, config, processing = default_forward_setup()
    d = config["diagnosis"]
    reference = next(f["reference"] for f in data["payload_flights"] if f["id"] == args.flight)
    with tempfile.TemporaryDirectory() as tmp:
        profile = cProfile.Profile()
        profile.enable()
        steps.forward_probes(args.results / "diagnosis" / "measured" / f"{args.flight}.json",
                             Path(tmp) / "forward.json", campaign=payload_flight_manifest(data, args.flight),
                             flight_id=args.flight, processing=processing, seeds=d["seeds"],
                             mast_l1=args.results / "netcdf" / "L1" / f"mast_{reference}.nc",
                             atmosphere=d["atmosphere"])
        profile.disable()
    stats = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    total = max(v[3] for v in stats.values())
    functions = {}
    for name in args.functions:
        # of functions sharing the name (pandas' duplicated calls its namesakes) the outermost,
        # the one with the largest cumulative time: summing them would count nested calls twice
        rows = [(v[3], v[1], f"{Path(path).name}:{line}") for (path, line, fname), v in stats.items()
                if fname == name or fname.endswith(f".{name}>")]  # built-ins: "<built-in method m.name>"
        if rows:
            cumulative, calls, where = max(rows)
            functions[name] = {"where": where, "calls": calls, "cumulative_s": round(cumulative, 3),
                               "share": round(cumulative / total, 4)}
    remembered = {}
    for module, name in REMEMBERED:
        fn = getattr(importlib.import_module(module), name, None)
        if fn is not None and hasattr(fn, "cache_info"):
            info = fn.cache_info()
            remembered[name] = {"made": info.misses, "reused": info.hits}
    print_and_write({"commit": git_commit(Path(steps.__file__).parent), "results": str(args.results),
                     "flight": args.flight, "profiled_total_s": round(total, 3), "functions": functions,
                     "remembered": remembered}, args.out)


if __name__ == "__main__":
    main()
