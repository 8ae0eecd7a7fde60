"""Snakemake script: reference mast sonic L1 -> L2 over one flight's hover window."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged, mast_l2

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    mast_l2(sm.input.mast, sm.input.drone, sm.output[0], **sm.params)
