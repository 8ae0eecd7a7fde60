"""Snakemake script: quadrotor figures (Wetz et al. 2021 Figs 3-9) from stored tables and L2 files."""

from dronewind.figures.quadrotor import quadrotor_figures
from dronewind.steps import logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    quadrotor_figures(sm.params.tables_dir, sm.input.summary, list(sm.input.l2), sm.input.reference, list(sm.output))
