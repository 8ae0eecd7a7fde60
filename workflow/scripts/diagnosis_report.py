"""Snakemake script: diagnosis report (before/after numbers, Markdown, figures)."""

from pathlib import Path

from dronewind.steps import logged
from dronewind.steps.diagnosis import diagnosis_report

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    diagnosis_report(sm.input.diagnosis, list(sm.input.measured), list(sm.input.forward), list(sm.input.extended),
                     sm.output.md, sm.output.csv, Path(sm.output.png).parent)
