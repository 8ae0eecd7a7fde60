"""Snakemake script: one mast sonic, raw files in their declared format (L0) -> L1."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged, mast_l1

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    mast_l1(list(sm.input.files), sm.output[0], **sm.params)
