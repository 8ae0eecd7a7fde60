"""Snakemake script: the block-series figure from tables/block_stats.csv."""

from pathlib import Path

from dronewind.figures.blocks import block_series
from dronewind.steps import logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    block_series(sm.input[0], Path(sm.output.png).with_suffix(""))
