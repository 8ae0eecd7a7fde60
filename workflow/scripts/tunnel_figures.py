"""Snakemake script: wind-tunnel figures (Kistner et al. 2024 Figs 4-7, 9) from the stored tables."""

from dronewind.figures.quadrotor import tunnel_figures
from dronewind.steps import logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    tunnel_figures(sm.params.tables_dir, list(sm.output))
