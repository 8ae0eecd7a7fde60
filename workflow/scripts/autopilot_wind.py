"""Snakemake script: one autopilot flight, tilt wind and EKF wind (L3) and their statistics (L4)."""

from dronewind.steps import logged
from dronewind.steps.autopilot import autopilot_wind

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    autopilot_wind(sm.params.campaign, sm.params.flight, sm.input.raw, sm.params.site, sm.output.l3, sm.output.l4,
                   simulated=sm.params.simulated)
