"""Snakemake script: payload L1 -> L2 (synchronised, motion-corrected east/north/up)."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged, payload_l2

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    payload_l2(sm.input.sonic, sm.input.ins, sm.output[0], **sm.params)
