"""Snakemake script: one part of the campaign diagnosis' bootstrap reference (.npz)."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import diagnosis_reference

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    diagnosis_reference(list(sm.input.measured), list(sm.input.forward), sm.output[0], **sm.params)
