"""Snakemake script: payload sonic and INS, L0 -> L1."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged, payload_l1

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    payload_l1(sm.input.sonic, sm.input.ins, sm.output.sonic, sm.output.ins, **sm.params)
