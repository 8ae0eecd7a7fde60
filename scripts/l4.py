"""Snakemake script: L3 -> L4 (statistics, spectra, fits, uncertainties, scales) for one sensor."""

from dronewind.steps.preload import delegate

delegate()  # a local run's preloaded process takes the job from here (dronewind.steps.preload)

from dronewind.steps import l4, logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    l4(sm.input.l3, sm.output[0], **sm.params)
