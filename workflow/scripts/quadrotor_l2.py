"""Snakemake script: every UAV of every quadrotor flight, L1 -> calibrated 1 Hz wind (L2)."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_l2_flight

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    l1, l2 = list(sm.input.l1), list(sm.output)
    start = 0
    for flight_id, uavs in sm.params.flights.items():
        end = start + len(uavs)
        quadrotor_l2_flight(sm.params.campaign, flight_id, uavs, l1[start:end], sm.input.calibration,
                            sm.input.summary, sm.params.site, l2[start:end], sm.params.average_s, sm.params.hover)
        start = end
