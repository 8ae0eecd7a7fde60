"""Snakemake script: one UAV log of a quadrotor flight, L0 -> L1 NetCDF."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_l1

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    quadrotor_l1(sm.params.campaign, sm.wildcards.qflight, sm.wildcards.quav, sm.input.raw, sm.params.site,
                 sm.output[0], simulated=sm.params.simulated)
