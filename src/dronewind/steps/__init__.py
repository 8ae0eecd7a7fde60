"""The orchestrator: one function per workflow step, from files to files.

Each step reads its inputs, calls the chain functions (datasets in, datasets out:
:mod:`dronewind.payload.chain`, :mod:`dronewind.mast.chain`, :mod:`dronewind.compare.chain`)
with the settings it is given, and writes its outputs (NetCDF through
:func:`dronewind.steps.payload.write_product`, tables atomically). The Snakemake scripts in
``scripts/`` call these functions with the rule's ``params`` as keyword arguments, so a
step can be rerun and debugged by hand without Snakemake. Besides ``cli``, this package is
the only place that does file I/O for the workflow; the science lives in the topical modules.

Modules: :mod:`~dronewind.steps.common` (logging, campaign record, product reader),
:mod:`~dronewind.steps.payload` (SAMURAI-S payload and mast chain, L0 to L4),
:mod:`~dronewind.steps.diagnosis` and :mod:`~dronewind.steps.published` (the diagnosis),
:mod:`~dronewind.steps.quadrotor` (SWUF-3D fleet and wind tunnel).
"""

from dronewind.steps.common import LOG, campaign_record, logged, open_product
from dronewind.steps.payload import (
    FLIGHT_STATS_COLUMNS,
    flight_stats,
    l3,
    l4,
    mast_l1,
    mast_l2,
    payload_l1,
    payload_l2,
    simulate_payload,
    simulation_manifest,
)

__all__ = [
    "LOG", "campaign_record", "logged", "open_product", "FLIGHT_STATS_COLUMNS", "flight_stats", "l3", "l4",
    "mast_l1", "mast_l2", "payload_l1", "payload_l2", "simulate_payload", "simulation_manifest",
]
