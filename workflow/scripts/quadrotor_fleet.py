"""Snakemake script: every quadrotor flight, L0 -> L1 -> averaging windows."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_l1_flight, quadrotor_windows

sm = snakemake  # noqa: F821 (snakemake is injected)
p = sm.params
with logged(sm.log[0]):
    for f in p.flights:
        flight = f["flight"]
        quadrotor_l1_flight(p.campaign, flight["id"], f["uavs"], f["raw"], p.site, f["l1"], simulated=p.simulated,
                            attribution=p.attribution, formats=f["formats"])
        quadrotor_windows(flight, dict(zip(f["uavs"], f["l1"], strict=True)), f["reference"], p.site_altitude_m,
                          p.block_s, p.hover, *f["windows"])
