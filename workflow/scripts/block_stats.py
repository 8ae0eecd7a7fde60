"""Snakemake script: the block L4 of every mast sonic -> tables/block_stats.csv."""

from dronewind.steps import logged
from dronewind.steps.blocks import block_stats

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    block_stats(list(sm.input), sm.output[0])
