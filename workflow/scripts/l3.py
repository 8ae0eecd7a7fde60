"""Snakemake script: the reference mast cut to the flight (mast L2), then L2 -> L3 (alignment, decimation, rotation)."""

from dronewind.steps import l3, logged, mast_l2

#: The rule's params that the mast L2 step takes.
MAST_L2_KEYS = ("campaign", "flight_id", "reference", "drone_mast")

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    mast_l2(sm.input.mast, sm.input.drone, sm.output.mast, **{k: sm.params[k] for k in MAST_L2_KEYS})
    l3(sm.input.drone, sm.output.mast, sm.output.l3, **sm.params)
