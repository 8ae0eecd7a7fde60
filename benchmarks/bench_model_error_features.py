"""How far each model-error truth moves the diagnosis' measured features, in their own sampling errors.

For every kind of dronewind.diagnose.experiments.MODEL_ERRORS, the first draws of that kind
in the stratified set (``--draws``, ``--seed``, all model errors) are simulated as the
4-flight hidden-effect campaign and processed to the measured residual features
(forward.measured_features, the diagnosis' input), once with the model error and once
without it at the same campaign seed (same turbulence latents, motion and noise draws).
The shift of each feature is divided by the feature's own sampling error (``sigma`` of
features.flight_features). No forward probes run: this measures what the truth does to
the data, not what the diagnosis makes of it (bench_diagnosis_rates.py does that).

    PYTHONPATH=src nice -n 5 .venv/bin/python benchmarks/bench_model_error_features.py \\
        --draws 12 --seed 1 --out benchmarks/results/model_error_features.json

``--model-error '<json>'`` (repeatable) replaces the draws by given settings by section,
e.g. ``'{"atmosphere": {"speed_trend_ms_per_h": 6}}'``, at campaign seed ``--seed``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from bench_common import git_commit
from dronewind.diagnose import experiments as ex
from dronewind.diagnose import in_process
from dronewind.manifest import with_defaults

REPO = Path(__file__).resolve().parents[1]


def measured(data: dict[str, Any], processing: dict[str, Any], work: Path) -> dict[str, dict[str, Any]]:
    """Measured features of every flight of a hidden-effect campaign (in_process.process_virtual_flight, no probes)."""
    from dronewind.diagnose import forward, probes
    from dronewind.diagnose.features import features_to_dict

    out = {}
    lag = {key: processing[key] for key in probes.LAG_SETTINGS}
    for flight in data["payload_flights"]:
        fid = flight["id"]
        v = in_process.process_virtual_flight(data, flight, work, processing)
        out[fid] = features_to_dict(forward.measured_features(data, fid, v.sonic_l1, v.ins_l1, v.l2, v.l3, **lag))
    return out


def shifts(with_error: dict[str, Any], without: dict[str, Any]) -> dict[str, Any]:
    """Per flight and feature: (with - without) / sigma (sigma of the run without the model error)."""
    z: dict[str, dict[str, float]] = {}
    for fid, feats in with_error.items():
        base = without[fid]
        z[fid] = {}
        for name, value in feats["values"].items():
            b, s = base["values"].get(name), base["sigma"].get(name)
            if value is None or b is None or not s:
                continue
            z[fid][name] = (value - b) / s
    flat = [(abs(v), fid, name) for fid, d in z.items() for name, v in d.items()]
    flat.sort(reverse=True)
    per_feature: dict[str, list[float]] = {}
    for d in z.values():
        for name, v in d.items():
            per_feature.setdefault(name, []).append(v)
    return {
        "rms_z": float(np.sqrt(np.mean([v[0] ** 2 for v in flat]))) if flat else float("nan"),
        "n_features": len(flat),
        "n_above_2": sum(v[0] > 2 for v in flat),
        "largest": [{"flight": fid, "feature": name, "z": float(z[fid][name])} for _, fid, name in flat[:6]],
        # combined over the 4 flights: mean shift / (1/sqrt(n)) (independent flights)
        "campaign_z": {name: float(np.mean(v) * np.sqrt(len(v))) for name, v in sorted(per_feature.items())},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--draws", type=int, default=12)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--model-error", action="append", default=[],
                        help="settings by simulation section as JSON (instead of the draws)")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks/results/model_error_features.json")
    args = parser.parse_args()
    processing = with_defaults(yaml.safe_load((REPO / "config/config.yaml").read_text()))["processing"]
    if args.model_error:
        draws = [ex.Draw("none", {}, args.seed, json.loads(text), "given") for text in args.model_error]
    else:
        draws = ex.stratified_draws(args.draws, args.seed, null_share=0.0, model_error_share=1.0)
    start, cpu0 = time.perf_counter(), time.process_time()
    results = []
    baselines: dict[int, dict[str, Any]] = {}
    for truth in draws:
        with tempfile.TemporaryDirectory() as work:
            if truth.seed not in baselines:
                baselines[truth.seed] = measured(ex.campaign_manifest(ex.Draw("none", {}, truth.seed)), processing,
                                                 Path(work) / "base")
            feats = measured(ex.campaign_manifest(truth), processing, Path(work) / "error")
        entry = {"label": truth.label, "model_error": truth.model_error, "seed": truth.seed,
                 **shifts(feats, baselines[truth.seed])}
        results.append(entry)
        top = entry["largest"][0] if entry["largest"] else {}
        print(f"{truth.label} {truth.model_error}: rms z {entry['rms_z']:.2f}, {entry['n_above_2']}/"
              f"{entry['n_features']} |z| > 2, largest {top}", flush=True)
    commit = git_commit()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "command": f"PYTHONPATH=src nice -n 5 .venv/bin/python benchmarks/bench_model_error_features.py "
                   f"--draws {args.draws} --seed {args.seed}"
                   + "".join(f" --model-error '{text}'" for text in args.model_error),
        "commit": commit, "wall_seconds": time.perf_counter() - start, "cpu_seconds": time.process_time() - cpu0,
        "draws": results}, indent=1))


if __name__ == "__main__":
    main()
