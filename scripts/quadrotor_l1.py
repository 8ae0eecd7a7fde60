"""Snakemake script: every UAV log of one quadrotor flight, L0 -> L1 NetCDF (one job per flight)."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_l1_flight

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    quadrotor_l1_flight(sm.params.campaign, sm.params.flight_id, sm.params.uavs, list(sm.input.raw), sm.params.site,
                        list(sm.output), simulated=sm.params.simulated, attribution=sm.params.attribution,
                        formats=sm.params.formats)
