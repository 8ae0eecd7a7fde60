"""Snakemake script: one mast sonic, raw files in their declared format (L0) -> L1."""

from dronewind.steps import logged, mast_l1

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    mast_l1(list(sm.input.files), sm.output[0], **sm.params)
