"""Snakemake script: campaign diagnosis (diagnosis.json and the extended campaign manifest)."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import diagnose_campaign

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    diagnose_campaign(sm.input.manifest, list(sm.input.measured), list(sm.input.forward), sm.output.json,
                      sm.output.manifest, platform_files=list(sm.input.platform),
                      reference_files=list(sm.input.reference), **sm.params)
