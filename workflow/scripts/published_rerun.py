"""Snakemake script: baseline and extended model of one published sample, fresh seeds."""

from dronewind.steps import logged
from dronewind.steps.published import published_rerun

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    published_rerun(sm.input.published[0], sm.input.diagnosis, sm.output[0], **sm.params)
