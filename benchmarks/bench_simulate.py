"""Throughput of the virtual payload campaign (dronewind.simulate).

Prints seconds to simulate (1) the turbulent field alone for one flight, (2) one
20-min payload flight (s10 of the default campaign: sonic + INS + two mast TOA5), and
(3) all ten payload flights of config/campaigns/mosai2023.yaml, on one core.
With ``--pyconturb`` it also times pyconturb.gen_turb on the same three points (u, v, w;
it cannot give the u-w and w-theta correlations), the measurement that motivated the
hand-written generator.

Run: ``.venv/bin/python benchmarks/bench_simulate.py [--pyconturb]``
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import yaml  # noqa: E402

from dronewind.simulate import atmosphere as atm  # noqa: E402
from dronewind.simulate.payload import simulate_payload_flight  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGN = ROOT / "config" / "campaigns" / "mosai2023.yaml"


def _best(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), float(np.median(times))


def main() -> None:
    data = yaml.safe_load(CAMPAIGN.read_text())
    pts = np.array([[0.0, 0.0, 30.0], [0.0, 0.0, 60.0], [30.0, -20.0, 49.0]])

    def field():
        spec = atm.field_coefficients(pts, 1800.0, 32.0, 7.1, 296.0, 60.0, 1200.0, 0.3,
                                      np.random.default_rng(1))
        atm.synthesize(spec, 32.0, [2])
        atm.synthesize(spec, 10.0, [0, 1])

    best, med = _best(field)
    print(f"field only (3 points, 30 min, 32 Hz + 10 Hz synthesis): best {best:.3f} s, median {med:.3f} s")

    with tempfile.TemporaryDirectory() as tmp:
        best, med = _best(lambda: simulate_payload_flight(data, CAMPAIGN.parent, "s10", Path(tmp) / "one"))
        print(f"one payload flight s10 (20.2 min hover, 2 mast sonics): best {best:.3f} s, median {med:.3f} s"
              f"  (target <= 2 s)")
        t0 = time.perf_counter()
        n_rows = 0
        for f in data["payload_flights"]:
            files = simulate_payload_flight(data, CAMPAIGN.parent, f["id"], Path(tmp) / "all")
            n_rows += sum(p.read_bytes().count(b"\n") for p in files)
        total = time.perf_counter() - t0
        print(f"all 10 payload flights of mosai2023: {total:.2f} s ({total / 10:.2f} s per flight, "
              f"{n_rows / 1e6:.2f} M rows written)")

    if "--pyconturb" in sys.argv:
        import pandas as pd
        from pyconturb import gen_turb
        cols = [[k, 0.0, y, z] for k in range(3) for y, z in ((0.0, 30.0), (0.0, 60.0), (30.0, 49.0))]
        spat = pd.DataFrame(np.array(cols).T, index=["k", "x", "y", "z"])
        t0 = time.perf_counter()
        gen_turb(spat, T=1200, nt=1200 * 32, u_ref=8.0, z_ref=49.0, coh_model="iec3d", seed=1)
        print(f"pyconturb.gen_turb, same 3 points x u,v,w, 20 min at 32 Hz: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
