"""Snakemake script: one mast sonic's L1 in blocks -> block L4 (blocks along time)."""

from dronewind.steps import logged
from dronewind.steps.blocks import mast_blocks

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    mast_blocks(sm.input[0], sm.output[0], **sm.params)
