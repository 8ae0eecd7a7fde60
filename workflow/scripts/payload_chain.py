"""Snakemake script: a payload flight's sonic and INS, L0 -> L1 -> L2 (synchronised, motion-corrected
east/north/up), the reference mast cut to the flight (mast L2), then L2 -> L3 (alignment, decimation, rotation)."""

from dronewind.steps import l3, logged, mast_l2, payload_l1, payload_l2

#: The rule's params each step takes.
L1_KEYS = ("campaign", "flight_id", "site", "target_height_m", "despike", "simulated", "data_root", "sonic_format",
           "ins_format", "attribution")
L2_KEYS = ("campaign", "flight_id", "site", "flight", "sonic_ins_lag", "hover", "max_missing_fraction")
MAST_L2_KEYS = ("campaign", "flight_id", "reference", "drone_mast")
L3_KEYS = ("campaign", "flight_id", "flight", "reference", "drone_mast", "rotation")

sm = snakemake  # noqa: F821 (snakemake is injected)
p, out = sm.params, sm.output
with logged(sm.log[0]):
    payload_l1(sm.input.sonic, sm.input.ins, out.sonic, out.ins, **{k: p[k] for k in L1_KEYS})
    payload_l2(out.sonic, out.ins, out.drone, **{k: p[k] for k in L2_KEYS})
    mast_l2(sm.input.mast, out.drone, out.mast, **{k: p[k] for k in MAST_L2_KEYS})
    l3(out.drone, out.mast, out.l3, **{k: p[k] for k in L3_KEYS})
