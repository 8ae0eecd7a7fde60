"""Snakemake script: one quadrotor flight, L0 -> L1 NetCDF per UAV and averaging windows."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_flight

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    uavs = list(sm.params.uavs)
    quadrotor_flight(sm.input.manifest, sm.params.flight, dict(zip(uavs, sm.input.uavs, strict=True)),
                     sm.input.reference, dict(zip(uavs, sm.output.l1, strict=True)), sm.output.windows,
                     sm.output.blocks, sm.output.problems, sm.config)
