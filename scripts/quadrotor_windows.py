"""Snakemake script: one quadrotor flight, the 10-min and 2-min averaging windows of its UAVs."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_windows

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    uavs = [u["id"] for u in sm.params.flight["uavs"]]
    quadrotor_windows(sm.params.flight, dict(zip(uavs, sm.input.l1, strict=True)), sm.input.reference,
                      sm.params.site_altitude_m, sm.params.block_s, sm.params.hover, sm.output.windows,
                      sm.output.blocks, sm.output.problems)
