"""Snakemake script: every UAV of one quadrotor flight, L1 -> calibrated 1 Hz wind (L2; one job per flight)."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_l2_flight

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    quadrotor_l2_flight(sm.params.campaign, sm.params.flight_id, sm.params.uavs, list(sm.input.l1),
                        sm.input.calibration, sm.input.summary, sm.params.site, list(sm.output), sm.params.average_s,
                        sm.params.hover)
