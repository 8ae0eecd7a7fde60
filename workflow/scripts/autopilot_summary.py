"""Snakemake script: the table of every autopilot flight's tilt wind against its EKF wind, a figure per flight."""

from dronewind.steps import logged
from dronewind.steps.autopilot import autopilot_summary

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    autopilot_summary(list(sm.input.l3), list(sm.input.l4), sm.output.table, list(sm.output.figures))
