"""Snakemake script: campaign figures (PNG and PDF), drawn from stored products only."""

from pathlib import Path

from dronewind.figures.campaign import draw_all
from dronewind.steps import logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    draw_all(Path(sm.params.results), Path(sm.output.png[0]).parent, names=sm.params.names)
