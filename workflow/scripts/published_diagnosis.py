"""Snakemake script: fit every mechanism to the paper's published numbers."""

from dronewind.steps import logged
from dronewind.steps.published import published_diagnosis

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    published_diagnosis(sm.input.published[0], list(sm.input.forward), sm.output[0], **sm.params)
