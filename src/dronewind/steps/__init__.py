"""The orchestrator: one function per workflow step, from files to files.

Each step reads its inputs, calls the chain functions (datasets in, datasets out:
:mod:`dronewind.payload.chain`, :mod:`dronewind.mast.chain`, :mod:`dronewind.compare.chain`)
with the settings it is given, and writes its outputs (NetCDF through
:func:`dronewind.steps.payload.write_product`, tables atomically). The Snakemake scripts in
``workflow/scripts/`` call these functions with the rule's ``params`` as keyword arguments, so a
step can be rerun and debugged by hand without Snakemake. Besides ``cli``, this package is
the only place that does file I/O for the workflow; the science lives in the topical modules.

Modules: :mod:`~dronewind.steps.common` (logging, campaign record, product reader),
:mod:`~dronewind.steps.payload` (SAMURAI-S payload and mast chain, L0 to L4),
:mod:`~dronewind.steps.diagnosis` and :mod:`~dronewind.steps.published` (the diagnosis),
:mod:`~dronewind.steps.quadrotor` (SWUF-3D fleet and wind tunnel).
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public names re-exported lazily (PEP 562), so that a job importing one step module does not
#: pay for importing every chain (scipy.signal alone takes about 1 s to import; a quadrotor
#: job runs in about 2 s).
_EXPORTS = {
    "LOG": "common", "campaign_record": "common", "logged": "common", "open_product": "common",
    "FLIGHT_STATS_COLUMNS": "payload", "flight_stats": "payload", "l3": "payload", "l4": "payload",
    "mast_l1": "payload", "mast_l2": "payload", "payload_l1": "payload", "payload_l2": "payload",
    "simulate_payload": "payload", "simulation_manifest": "payload",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"dronewind.steps.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'dronewind.steps' has no attribute {name!r}")
