"""A campaign with fewer usable payload flights than the diagnosis needs is reported, not a crash.

The chain leaves a flight out when its L2 is unusable (a hover window shorter than the
usable minimum, too many gaps, a failed convention check). A campaign may end with one usable
flight or none: a rope so long and draggy that the payload never settles left every flight of an
independent-world campaign with hover windows of 85-434 s. The diagnosis of such a campaign
names nothing and says why (``note``, ``unusable``), in the workflow's step and in the
in-process path alike, and the bootstrap reference of its jobs is empty.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dronewind.diagnose import campaign as dc
from dronewind.diagnose.features import FEATURES
from dronewind.diagnose.in_process import diagnose_evidence
from dronewind.diagnose.probes import MIN_FLIGHTS
from dronewind.diagnose.record import not_diagnosed_json
from dronewind.diagnose.report import markdown
from dronewind.manifest import default_config

REPO = Path(__file__).resolve().parents[2]
SIGMA = 0.05  # analytic error of every feature [feature units]


def _features(values: np.ndarray) -> dict:
    return {"values": {f: float(values[k]) for k, f in enumerate(FEATURES)}, "sigma": {f: SIGMA for f in FEATURES},
            "reasons": {}}


def _one_flight(rng: np.random.Generator, n_seeds: int = 30) -> tuple[dict, dict]:
    """Measured features and forward runs (baseline seeds, two w-gain probes) of one flight."""
    seeds = [rng.normal(0.0, SIGMA, len(FEATURES)) for _ in range(n_seeds)]
    probes = [{"candidate": "w_gain", "mechanism": "w_gain", "parameter": "gain", "level": level, "fixed": {},
               "features": _features(seeds[0] + (np.array(FEATURES) == "ln_sigma_ratio_w") * np.log(level))}
              for level in (0.85, 1.2)]
    forward = {"h01": {"flight": "h01", "conditions": {"mean_speed_ms": 6.0}, "seeds": list(range(n_seeds)),
                       "baseline": [_features(s) for s in seeds], "probes": probes}}
    return {"h01": _features(rng.normal(0.0, SIGMA, len(FEATURES)))}, forward


def test_a_campaign_without_a_usable_flight_assembles_to_no_flights():
    ev = dc.assemble({}, {})
    assert ev.flights == [] and ev.n_seeds == 0 and ev.models == {}
    assert ev.y.shape == ev.sigma.shape == ev.baseline.shape == (0, len(FEATURES))


@pytest.mark.parametrize("n_usable", [0, 1])
def test_in_process_diagnosis_names_nothing_and_says_why(n_usable):
    measured, forward = _one_flight(np.random.default_rng(3)) if n_usable else ({}, {})
    unusable = ["w02", "w01", "w03", "w04"][: 4 - n_usable]
    reasons = {f: "hover window 85.0 s shorter than 600 s" for f in unusable}
    evidence = {"name": "world", "measured": measured, "forward": forward, "unusable": unusable,
                "unusable_reasons": reasons}
    out = diagnose_evidence(evidence, default_config())
    assert out["unusable_reasons"] == reasons
    assert out["named_causes"] == [] and out["candidates"] == []
    assert "unexplained" not in out  # nothing was tested: no "nothing remains unexplained"
    assert out["note"] == f"{n_usable} usable flight(s): held-out scoring needs at least {MIN_FLIGHTS}"
    assert out["unusable"] == sorted(unusable)
    assert out["atmosphere"] == default_config()["diagnosis"]["atmosphere"]


def test_workflow_step_writes_the_same_record_and_an_empty_reference(tmp_path):
    from dronewind.steps.diagnosis import diagnose_campaign, diagnosis_reference

    measured_files = []
    for flight in ("s01", "s02"):
        path = tmp_path / f"{flight}.json"
        path.write_text(json.dumps({"flight": flight, "features": None, "conditions": None, "usable": 0,
                                    "reason": "hover window 220.6 s shorter than 600 s"}))
        measured_files.append(path)
    out = diagnose_campaign(REPO / "config" / "campaigns" / "mosai2023.yaml", measured_files, [],
                            tmp_path / "diagnosis.json", tmp_path / "extended.yaml", alpha=0.01, max_causes=3,
                            min_gain=0.05, atmosphere="measured")
    record = json.loads(out.read_text())
    reasons = {f: "hover window 220.6 s shorter than 600 s" for f in ("s01", "s02")}
    assert record == {**not_diagnosed_json("mosai2023", 0, reasons), "atmosphere": "measured"}
    text = markdown(record, {}, {}, [])
    assert "**Not diagnosed:** 0 usable flight(s)" in text
    assert "**Flights left out (unusable):** s01 (hover window 220.6 s shorter than 600 s); s02 (" in text
    assert "Nothing remains unexplained" not in text
    ref = diagnosis_reference(measured_files, [], tmp_path / "part.npz", bootstrap=600, part=0, parts=1)
    with np.load(ref) as arrays:
        assert int(arrays["n_replicates"]) == 0
