"""Snakemake script: one UAV of a quadrotor flight, L1 -> calibrated 1 Hz wind (L2)."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_l2

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    quadrotor_l2(sm.params.campaign, sm.wildcards.qflight, sm.wildcards.quav, sm.input.l1, sm.input.calibration,
                 sm.input.summary, sm.params.site, sm.output[0], sm.params.average_s, sm.params.hover)
