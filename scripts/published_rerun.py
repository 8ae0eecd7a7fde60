"""Snakemake script: baseline and extended model of one published sample, fresh seeds."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged
from dronewind.steps.published import published_rerun

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    published_rerun(sm.input.published, sm.input.diagnosis, sm.output[0], **sm.params)
