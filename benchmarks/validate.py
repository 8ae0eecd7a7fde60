"""Validation studies and whole-run timings (``make validate``): each writes one current result file.

Each study is a script of this folder run with the arguments below; its result replaces
``benchmarks/results/<study>.json``, stamped with the exact command and the processor it ran
on (``command`` and ``machine`` keys). The studies take from minutes to hours of CPU: run
one at a time on a quiet machine::

    make validate STUDY=metpy_agreement          # one study
    make validate                                # all of them, one after another (hours)
    .venv/bin/python benchmarks/validate.py --list

Studies marked ``needs a finished run`` read ``results/mosai2023`` (``make run`` first);
``ecpet_compare`` needs EC-PeT in its own environment (``--ecpet-python``, see
``bench_ecpet.py``). The timing suite of single stages is ``make bench`` (pytest-benchmark).
"""

from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
RESULTS = HERE / "results"
sys.path.insert(0, str(HERE))


@dataclass(frozen=True)
class Study:
    """One study: its script, arguments, what it validates, and what it needs first."""

    script: str
    args: tuple[str, ...]
    what: str
    needs: str = ""
    out_option: bool = True  # the script takes --out (else it writes RESULTS/<name>.json itself)


FINISHED = "a finished default run (make run)"

#: Study name (= result file stem) -> how it is made.
STUDIES: dict[str, Study] = {
    # agreement with independent implementations
    "metpy_agreement": Study("metpy_agreement.py", ("--results", "{tmp}/real_ameriflux_gold", "{tmp}/real_fluxpart"),
                             "block statistics of the real tower records against MetPy",
                             "the two real tower campaigns, run by this script's pre-step"),
    "ecpet_compare": Study("bench_ecpet.py", (), "block statistics and cost against EC-PeT on the real tower records",
                           "EC-PeT's own environment: pass --args '--ecpet-python /path/to/python'"),
    # the diagnosis: detection and false-alarm rates
    "diagnosis_rates": Study("bench_diagnosis_rates.py", ("--draws", "30", "--seed", "1", "--workers", "2",
                                                          "--null-share", "0.2", "--model-error-share", "0.15"),
                             "detection, false-alarm and estimate-error rates over stratified hidden-effect draws"),
    "diagnosis_model_errors_measured": Study(
        "bench_diagnosis_rates.py", ("--draws", "12", "--seed", "1", "--workers", "2", "--null-share", "0.0",
                                     "--model-error-share", "1.0", "--only",
                                     "model_error:turbulence,model_error:mean_wind,model_error:mast"),
        "model errors no mechanism describes: reported as unexplained, never named"),
    "diagnosis_lags": Study("bench_diagnosis_rates.py", ("--draws", "160", "--seed", "11", "--workers", "2",
                                                         "--null-share", "0.0", "--model-error-share", "0.0",
                                                         "--only", "attitude_lag,sonic_ins_lag"),
                            "the two lag mechanisms told apart"),
    "diagnosis_mast_distortion": Study(
        "bench_diagnosis_rates.py", ("--draws", "96", "--seed", "7", "--workers", "1", "--null-share", "0.0",
                                     "--model-error-share", "1.0", "--only", "model_error:mast_flow_distortion"),
        "mast flow distortion as a model error"),
    "null_calibration": Study("validate_null_calibration.py",
                              ("--draws", "60", "--workers", "2", "--replicates", "200"),
                              "calibration of the diagnosis on null campaigns, offsets and trends"),
    "diagnosis_independent_world": Study("validate_independent_world.py",
                                         ("--draws", "60", "--seed", "11", "--workers", "2", "--order", "interleaved"),
                                         "rates on campaigns written by an independent simulated world, and what the "
                                         "forward model gets wrong there by feature (`feature_offsets`)"),
    "diagnosis_independent_world_seed12": Study(
        "validate_independent_world.py", ("--draws", "60", "--seed", "12", "--workers", "2", "--order", "interleaved"),
        "the same rates on a second plan of 60 draws (docs/diagnosis.md pools the two)"),
    "diagnosis_independent_world_rope": Study(
        "validate_independent_world.py",
        ("--draws", "60", "--seed", "11", "--workers", "2", "--order", "interleaved", "--only",
         "none,model_error,attitude_lag", "--forward-payload", "rope_pitch_fraction=1,rope_roll_fraction=1",
         "--evidence-dir", "benchmarks/results/diagnosis_independent_world_rope_evidence"),
        "the first plan's null, model-error and attitude-lag draws with the forward model's payload attitude "
        "following its line (diagnosis.forward_payload), as that world's payload hangs"),
    "hidden_identifiability": Study("bench_identifiability.py", (),
                                    "is each mechanism identifiable at a physical size"),
    "model_error_features": Study("bench_model_error_features.py", ("--draws", "12", "--seed", "1"),
                                  "how far each model-error truth moves the measured features"),
    "model_error_features_trend_extremes": Study(
        "bench_model_error_features.py",
        ("--draws", "12", "--seed", "777", "--model-error", '{"atmosphere": {"speed_trend_ms_per_h": 6.0}}',
         "--model-error", '{"atmosphere": {"direction_trend_deg_per_h": 80.0}}', "--model-error",
         '{"atmosphere": {"speed_trend_ms_per_h": -6.0, "direction_trend_deg_per_h": -80.0}}'),
        "the same for extreme trends of the mean wind"),
    "platform_response_rates": Study("bench_platform_response_rates.py", (),
                                     "rates of the rigid-mount platform-response diagnosis", out_option=False),
    # the forward model
    "forward_atmosphere": Study("bench_forward_atmosphere.py", (), "the measured against the model atmosphere"),
    "measured_atmosphere_scatter": Study("measured_atmosphere_scatter.py", ("--realisations", "100", "--seeds", "4"),
                                         "seed scatter of the measured-atmosphere forward model"),
    "mechanism_scatter": Study("mechanism_scatter.py", ("s05", "attitude_lag:lag_s=0.3", "sonic_ins_lag:lag_s=0.27",
                                                        "--seeds", "10"),
                               "seed scatter of the features with a mechanism on", FINISHED),
    "pitch_response": Study("pitch_response.py", ("--results", "results/mosai2023", "s02", "s05", "s09"),
                            "linearity of the features in a sonic mount pitch", FINISHED),
    # planning, robustness
    "plan_validation": Study("plan_validation.py", ("--seeds", "20", "--flights", "3", "--draws", "60",
                                                    "--workers", "2"), "dronewind plan against simulated campaigns"),
    "plan_validation_long_hover": Study("plan_validation.py", ("--seeds", "60", "--flights", "2", "--draws", "20",
                                                               "--curve-draws", "10", "--workers", "1", "--no-rigid",
                                                               "--plans", "long_hover_high_wind"),
                                        "the same for a plan of long hovers in high wind"),
    "plan_validation_rigid": Study("plan_validation.py", ("--seeds", "100", "--workers", "1", "--rigid-only"),
                                   "the same for rigid-mount plans (uncertainties, 100 seeds per flight)"),
    "plan_reference_agreement": Study("plan_reference_agreement.py", ("--gain", "1.05", "1.08", "--flights", "3",
                                                                      "--draws", "30"),
                                      "the planner's shared bootstrap reference against each draw's own, paired draws"),
    "soak_faults": Study("soak_faults.py", (), "20 seeded faults in a 6-flight measured campaign, one run",
                         out_option=False),
    "reader_fuzzing": Study("bench_reader_fuzzing.py", ("800",), "every reader under byte-level logger faults",
                            out_option=False),
    "fork_lock": Study("bench_fork_lock.py", ("--n", "3000", "--busy", "3"),
                       "HDF5 file locking in a process that forks while it writes NetCDF"),
    # whole runs and long records
    "long_record": Study("bench_long_record.py", ("--days", "3", "10", "30", "--workers", "1"),
                         "30 days of 20 Hz TOA5 in bounded memory"),
    "long_record_2workers": Study("bench_long_record.py", ("--days", "3", "10", "30", "--workers", "2"),
                                  "the same with two threads"),
    "run_default": Study("bench_run.py", ("default",), "wall and CPU time of make run, per stage"),
    "run_measured6": Study("bench_run.py", ("measured6",), "wall and CPU time of a 6-flight measured campaign"),
    "test_suite": Study("bench_test_suite.py", (), "wall and CPU time of make test, per test"),
    "snakemake_start": Study("bench_snakemake_start.py", ("--repeat", "5"), "CPU of one Snakemake start"),
    "compliance": Study("bench_compliance.py", ("results/mosai2023",), "CF/ACDD check of every file of a run",
                        FINISHED),
}


def _prepare(name: str, tmp: Path) -> None:
    """What a study needs made first (the real tower campaigns of metpy_agreement)."""
    if name != "metpy_agreement":
        return
    blocks_15min = ["--configfile", "config/blocks_15min.yaml"]  # the fluxpart record spans 30 min off the hour
    for campaign, extra in (("real_ameriflux_gold", []), ("real_fluxpart", blocks_15min)):
        cmd = [str(Path(sys.executable).parent / "snakemake"), "--cores", "2", *extra, "--config",
               f"campaign={REPO / 'config' / 'campaigns' / (campaign + '.yaml')}", f"results_dir={tmp}"]
        print("+", shlex.join(cmd), flush=True)
        subprocess.run(cmd, cwd=REPO, check=True)


def run(name: str, extra: list[str]) -> int:
    """Run one study and stamp its result file with the command and the processor."""
    from bench_common import machine

    study = STUDIES[name]
    out = RESULTS / f"{name}.json"
    with tempfile.TemporaryDirectory() as tmp:
        _prepare(name, Path(tmp))
        args = [a.replace("{tmp}", tmp) for a in study.args]
        cmd = [sys.executable, str(HERE / study.script), *args, *extra]
        if study.out_option:
            cmd += ["--out", str(out)]
        shown = shlex.join(["python", f"benchmarks/{study.script}", *study.args, *extra,
                            *(["--out", f"benchmarks/results/{name}.json"] if study.out_option else [])])
        print(f"=== {name}: {shown}", flush=True)
        t0 = time.perf_counter()
        rc = subprocess.call(cmd, cwd=REPO)
    print(f"=== {name}: exit {rc}, {time.perf_counter() - t0:.0f} s wall", flush=True)
    if out.is_file():
        result = json.loads(out.read_text())
        if isinstance(result, dict):
            result["command"] = shown
            result.setdefault("machine", machine())
            out.write_text(json.dumps(result, indent=1) + "\n")
    return rc


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("studies", nargs="*", help="studies to run (default: all)")
    parser.add_argument("--list", action="store_true", help="list the studies and their result files")
    parser.add_argument("--args", default="", help="extra arguments passed to the study's script")
    ns = parser.parse_args(argv)
    if ns.list:
        for name, s in STUDIES.items():
            print(f"{name:40s} {s.script:32s} {s.what}" + (f" [needs {s.needs}]" if s.needs else ""))
        return 0
    unknown = sorted(set(ns.studies) - set(STUDIES))
    if unknown:
        parser.error(f"unknown studies {unknown}; expected some of: {', '.join(STUDIES)}")
    failed = [n for n in ns.studies or list(STUDIES) if run(n, shlex.split(ns.args))]
    if failed:
        print(f"failed: {failed}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
