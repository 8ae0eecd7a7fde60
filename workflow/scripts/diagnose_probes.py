"""Snakemake script: a processed flight's residual features, the first third of its baseline seeds, every probe."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import forward_probes, measured_features

#: The rule's params that the measured-features step takes (the others are the forward runs').
MEASURED_KEYS = ("campaign", "flight_id", "sonic_ins_lag", "hover", "max_missing_fraction", "forward_payload")
FORWARD_KEYS = ("campaign", "flight_id", "processing", "seeds", "atmosphere", "parts")

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    measured_features(sm.input.sonic, sm.input.ins, sm.input.drone, sm.input.l3, sm.output.measured,
                      **{k: sm.params[k] for k in MEASURED_KEYS})
    forward_probes(sm.output.measured, sm.output.probes, mast_l1=sm.input.mast,
                   **{k: sm.params[k] for k in FORWARD_KEYS})
