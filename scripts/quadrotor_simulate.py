"""Snakemake script: simulate one quadrotor flight (UAV CSVs and tower reference)."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged
from dronewind.steps.quadrotor import simulate_quadrotor

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    simulate_quadrotor(sm.params.flight, sm.params.simulation, sm.params.site, sm.params.out_dir)
