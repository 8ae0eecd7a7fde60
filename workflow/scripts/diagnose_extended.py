"""Snakemake script: rerun one flight with the extended model (named causes at their fits)."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import extended_run

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    extended_run(sm.input.manifest, sm.output[0], mast_l1=sm.input.mast, **sm.params)
