"""Snakemake script: report and figure of the published-numbers diagnosis."""

from dronewind.steps import logged
from dronewind.steps.published import published_report

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    published_report(sm.input.published[0], sm.input.diagnosis, list(sm.input.rerun), sm.output.md, sm.output.json,
                     sm.output.png, sm.output.pdf)
