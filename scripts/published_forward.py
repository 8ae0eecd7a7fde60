"""Snakemake script: forward-model runs of one published sample at its Table 4 conditions."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged
from dronewind.steps.published import published_forward

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    published_forward(sm.input.published, sm.output[0], **sm.params)
