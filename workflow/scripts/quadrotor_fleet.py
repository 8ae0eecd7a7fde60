"""Snakemake script: every quadrotor flight, L0 (simulated in a virtual campaign) -> L1 -> averaging windows."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_l1_flight, quadrotor_windows, simulate_quadrotor

sm = snakemake  # noqa: F821 (snakemake is injected)
p = sm.params
with logged(sm.log[0]):
    for f in p.flights:
        flight = f["flight"]
        if p.simulated:
            simulate_quadrotor(flight, f["simulation"], p.site, p.l0_dir)
        quadrotor_l1_flight(p.campaign, flight["id"], f["uavs"], f["raw"], p.site, f["l1"], simulated=p.simulated,
                            attribution=p.attribution, formats=f["formats"])
        quadrotor_windows(flight, dict(zip(f["uavs"], f["l1"], strict=True)), f["reference"], p.site_altitude_m,
                          p.block_s, p.hover, *f["windows"])
