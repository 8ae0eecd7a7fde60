"""Snakemake script: drone L2 -> drone-only L3 (a flight without a reference mast)."""

from dronewind.steps import logged
from dronewind.steps.payload import drone_l3

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    drone_l3(sm.input.drone, sm.output[0], **sm.params)
