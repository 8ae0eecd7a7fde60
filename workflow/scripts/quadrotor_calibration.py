"""Snakemake script: quadrotor fleet calibration and tables (Wetz et al. 2021 Sect. 5)."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_calibration

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    quadrotor_calibration(sm.params.campaign, list(sm.input.windows), list(sm.input.blocks), list(sm.input.problems),
                          sm.params.tables_dir, sm.output.summary, sm.params.calibration_window_s,
                          roles=sm.params.roles)
