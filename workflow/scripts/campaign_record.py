"""Snakemake script: write results/<name>/campaign.json (the validated manifest and provenance)."""

from dronewind.steps import campaign_record, logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    campaign_record(sm.input.manifest, sm.output[0], **sm.params)
