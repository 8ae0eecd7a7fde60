"""Snakemake script: L3 -> L4 (statistics, spectra, fits, uncertainties, scales) of a flight's drone and mast."""

from dronewind.steps import l4, logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    for sensor in ("drone", "mast"):
        l4(sm.input.l3, sm.output[sensor], sensor=sensor, **sm.params)
