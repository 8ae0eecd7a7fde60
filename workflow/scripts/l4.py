"""Snakemake script: L3 -> L4 (statistics, spectra, fits, uncertainties, scales) for one sensor."""

from dronewind.steps import l4, logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    l4(sm.input.l3, sm.output[0], **sm.params)
