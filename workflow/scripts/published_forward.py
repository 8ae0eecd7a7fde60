"""Snakemake script: forward-model runs of one published sample at its Table 4 conditions."""

from dronewind.steps import logged
from dronewind.steps.published import published_forward

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    published_forward(sm.input.published[0], sm.output[0], **sm.params)
