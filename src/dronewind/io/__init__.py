"""Readers of raw (L0) records into L1 datasets.

Payload (sonic + INS CSV), Campbell TOA5 mast sonic files and the AmeriFlux open-path
"gold" files. See ``../shared/DESIGN.md`` (data contract) for the formats.
"""

from dronewind.io.ameriflux import (
    gill_to_enu,
    read_ameriflux_gold,
    read_ameriflux_gold_blocks,
)
from dronewind.io.payload import (
    ClockFit,
    ClockJumpError,
    fit_logger_clock,
    ins_l1,
    payload_sonic_l1,
    read_ins_csv,
    read_sonic_csv,
)
from dronewind.io.toa5 import csat3_to_enu, mast_l1, read_toa5

__all__ = [
    "ClockFit",
    "ClockJumpError",
    "csat3_to_enu",
    "fit_logger_clock",
    "gill_to_enu",
    "ins_l1",
    "mast_l1",
    "payload_sonic_l1",
    "read_ameriflux_gold",
    "read_ameriflux_gold_blocks",
    "read_ins_csv",
    "read_sonic_csv",
    "read_toa5",
]
