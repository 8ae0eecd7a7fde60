"""The orchestrator: one function per workflow step, from files to files.

Each step reads its inputs, calls the pure library functions and writes its outputs
(NetCDF through :mod:`dronewind.core.cf`, tables atomically). The Snakemake scripts in
``scripts/`` and the ``dronewind`` command line both call these functions, so a step can
be rerun and debugged by hand without Snakemake. Besides ``cli``, this package is the only
place that does file I/O for the workflow; the science lives in the topical modules.

Modules: :mod:`~dronewind.steps.common` (logging, campaign record, product reader),
:mod:`~dronewind.steps.payload` (SAMURAI-S payload and mast chain, L0 to L4).
"""

from dronewind.steps.common import LOG, campaign_record, logged, open_product
from dronewind.steps.payload import (
    FLIGHT_STATS_COLUMNS,
    compute_l3,
    compute_l4,
    compute_mast_l1,
    compute_mast_l2,
    compute_payload_l1,
    compute_payload_l2,
    flight_stats,
    l3,
    l4,
    mast_l1,
    mast_l2,
    payload_l1,
    payload_l2,
    simulate_payload,
)

__all__ = [
    "LOG", "campaign_record", "logged", "open_product", "FLIGHT_STATS_COLUMNS", "compute_l3", "compute_l4",
    "compute_mast_l1", "compute_mast_l2", "compute_payload_l1", "compute_payload_l2", "flight_stats", "l3", "l4",
    "mast_l1", "mast_l2", "payload_l1", "payload_l2", "simulate_payload",
]
