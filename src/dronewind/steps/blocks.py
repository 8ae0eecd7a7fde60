"""Tower and mast records in blocks, step by step: a sonic's L1 to its block L4, the L4 to ``block_stats.csv``.

A campaign without drone flights (masts or towers only) gets, per mast sonic, the L4 of
every block of ``processing.block_s`` (:mod:`dronewind.compare.blocks`: coverage test, gap
filling, rotation, the flight L4 of a mast sensor) in one CF timeSeries file with the blocks
along ``time`` (:func:`dronewind.compare.blocks.stack_blocks`), and the campaign table
``tables/block_stats.csv`` assembled from those files (docs/data-contract.md, "Outputs that other tools
read"). The Snakemake rules (``workflow/rules/blocks.smk``) pass the settings as params.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dronewind.steps.common import LOG

# The block analysis and the NetCDF writer are imported in the functions that run it: the
# Snakefile imports block_settings each time Snakemake starts (on a cluster, once per job),
# and importing them would load xarray, pandas and scipy for that alone.

__all__ = ["BLOCK_SETTINGS", "block_settings", "mast_blocks", "block_stats"]

#: ``processing`` keys the block analysis reads (the params of rule mast_blocks).
BLOCK_SETTINGS = ("block_s", "rotation", "detrending", "max_missing_fraction", "spectra", "quadrant")


def block_settings(processing: Mapping[str, Any]) -> dict[str, Any]:
    """The ``processing`` keys of the block analysis (:data:`BLOCK_SETTINGS`).

    Parameters
    ----------
    processing : mapping
        ``config["processing"]``.

    Returns
    -------
    dict
        The keys of :data:`BLOCK_SETTINGS` that are set.
    """
    return {key: processing[key] for key in BLOCK_SETTINGS if key in processing}


def mast_blocks(l1_file: str | Path, output: str | Path, *, campaign: str, sonic: Mapping[str, Any],
                processing: Mapping[str, Any]) -> Path:
    """L1 of one mast sonic -> L4 of its blocks (one NetCDF, blocks along ``time``).

    Parameters
    ----------
    l1_file : str or Path
        The sonic's L1 (rule mast_l1).
    output : str or Path
        Block L4 NetCDF.
    campaign : str
        Campaign name.
    sonic : mapping
        The sonic's manifest entry with its mast's id and position (``id``, ``mast_id``,
        ``height_m`` [m], ``latitude``, ``longitude`` [degree]).
    processing : mapping
        :func:`block_settings` of the configuration (``block_s`` [s], ``rotation``,
        ``detrending``, ``max_missing_fraction`` [1], ``spectra``, ``quadrant``).

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.compare.blocks import BlockSettings, record_blocks, stack_blocks
    from dronewind.core.cf import write_netcdf
    from dronewind.core.cf_names import strip_cf
    from dronewind.core.products import open_product

    settings = BlockSettings.from_processing(processing)
    l1 = strip_cf(open_product(l1_file))
    blocks = record_blocks(l1, settings)
    stacked = stack_blocks(blocks)
    n_ok = int(stacked.attrs["n_usable_blocks"])
    LOG.info("mast %s: %d blocks of %g s, %d usable (detrending %s, rotation %s)", sonic["id"], len(blocks),
             settings.block_s, n_ok, settings.detrending, settings.rotation)
    return write_netcdf(
        stacked, output, title=f"{campaign} mast sonic {sonic['id']}: statistics and spectra in blocks, L4",
        summary=(f"Sonic {sonic['id']} at {float(sonic['height_m']):g} m on mast {sonic['mast_id']} in blocks of "
                 f"{settings.block_s:g} s aligned to UTC: mean wind, standard deviations, fluxes, friction "
                 "velocity, Obukhov length, spectra with model fits, quadrant ratios, random-error estimates and "
                 "integral scales per block (Ghirardelli et al. (2025), Sects. 4.1-4.4)."),
        processing_level="L4: statistics, spectra, uncertainties, scales in blocks",
        history=f"mast_blocks {sonic['id']}", inputs=[l1_file], config={"processing": dict(processing)},
        feature_type="timeSeries", station_id=str(sonic["id"]), latitude=sonic.get("latitude"),
        longitude=sonic.get("longitude"), height_m=float(sonic["height_m"]),
        extra_attrs={"campaign": campaign, "mast": str(sonic["mast_id"]), "sonic": str(sonic["id"])},
        nonstandard_group="analysis",
    )


def block_stats(l4_files: Sequence[str | Path], output: str | Path) -> Path:
    """Assemble ``tables/block_stats.csv`` from the block L4 of every sonic.

    Parameters
    ----------
    l4_files : sequence of path
        Block L4 files (:func:`mast_blocks`), one per sonic.
    output : str or Path
        CSV to write (atomically).

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.compare.blocks import block_stats_table, stacked_block_rows
    from dronewind.core.cf import atomic_write_text
    from dronewind.core.products import open_product

    rows = []
    for path in l4_files:
        ds = open_product(path)
        rows += stacked_block_rows(ds, str(ds.attrs["mast"]), str(ds.attrs["sonic"]))
    table = block_stats_table(rows)
    LOG.info("block_stats: %d blocks of %d sonic(s), %d usable", len(table), len(l4_files), int(table["usable"].sum()))
    return atomic_write_text(output, table.to_csv(index=False, na_rep="", lineterminator="\n"))
