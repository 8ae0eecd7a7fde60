"""Snakemake script: payload sonic and INS, L0 -> L1 -> L2 (synchronised, motion-corrected east/north/up)."""

from dronewind.steps import logged, payload_l1, payload_l2

#: The rule's params that the L2 step takes (the others are the L1 step's, with campaign, flight_id and site).
L2_KEYS = ("flight", "sonic_ins_lag", "hover", "max_missing_fraction")
COMMON_KEYS = ("campaign", "flight_id", "site")

sm = snakemake  # noqa: F821 (snakemake is injected)
params = dict(sm.params)
with logged(sm.log[0]):
    payload_l1(sm.input.sonic, sm.input.ins, sm.output.sonic, sm.output.ins,
               **{k: v for k, v in params.items() if k not in L2_KEYS})
    payload_l2(sm.output.sonic, sm.output.ins, sm.output.drone,
               **{k: params[k] for k in COMMON_KEYS + L2_KEYS})
