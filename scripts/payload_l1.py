"""Snakemake script: payload sonic and INS, L0 -> L1."""

from dronewind.steps import logged, payload_l1

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    payload_l1(sm.input.sonic, sm.input.ins, sm.output.sonic, sm.output.ins, **sm.params)
