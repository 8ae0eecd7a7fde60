"""Snakemake script: the UAV logs and tower reference of every quadrotor flight of a virtual campaign (L0)."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import simulate_quadrotor

sm = snakemake  # noqa: F821 (snakemake is injected)
p = sm.params
with logged(sm.log[0]):
    for f in p.flights:
        simulate_quadrotor(f["flight"], f["simulation"], p.site, p.l0_dir)
