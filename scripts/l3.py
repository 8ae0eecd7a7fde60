"""Snakemake script: L2 -> L3 (drone-mast alignment, decimation, rotation)."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import l3, logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    l3(sm.input.drone, sm.input.mast, sm.output[0], **sm.params)
