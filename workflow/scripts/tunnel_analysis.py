"""Snakemake script: wind-tunnel analysis tables (Kistner et al. 2024)."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import tunnel_analysis

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    tunnel_analysis(sm.params.campaign, sm.input.runs[0], sm.params.tables_dir)
