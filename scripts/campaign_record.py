"""Snakemake script: write results/<name>/campaign.json (the validated manifest and provenance)."""

from dronewind.steps import campaign_record, logged

with logged(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    campaign_record(snakemake.input.manifest, snakemake.output[0], snakemake.config)  # noqa: F821
