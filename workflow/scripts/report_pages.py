"""Snakemake script: the HTML report's front page, table pages and figure captions."""

from dronewind.steps import logged
from dronewind.steps.report import report_pages

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    report_pages(sm.params.results, sm.params.out_dir, sm.params.figures, sm.params.tables)
