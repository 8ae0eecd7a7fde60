"""Snakemake script: simulate the wind-tunnel programme (Kistner et al. 2024)."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import simulate_tunnel

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    simulate_tunnel(sm.params.simulation, sm.params.runs, sm.params.out_dir)
