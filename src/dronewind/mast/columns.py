"""Column layouts of the mast's raw records (data contract), apart from their readers.

The raw-format checks that run at every Snakemake start (:mod:`dronewind.formats`) need the
column names, not the readers, which import xarray (a few tenths of a CPU-second at each
start, i.e. once per job on a cluster). The readers (:mod:`dronewind.mast.toa5`,
:mod:`dronewind.mast.ameriflux`) use these names.
"""

from __future__ import annotations

__all__ = ["REQUIRED_TOA5_COLUMNS", "AMERIFLUX_GOLD_COLUMNS"]

#: Columns a CSAT3 TOA5 table must hold (data contract).
REQUIRED_TOA5_COLUMNS: tuple[str, ...] = (
    "TIMESTAMP", "RECORD", "Ux", "Uy", "Uz", "Ts", "diag_csat",
)  # fmt: skip
#: Column order of the numeric fields of an AmeriFlux gold file (source notes, "Data columns").
AMERIFLUX_GOLD_COLUMNS: tuple[str, ...] = ("w", "u", "v", "t_sonic_c", "h2o_v", "co2_v")
