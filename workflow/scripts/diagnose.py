"""Snakemake script: campaign diagnosis (diagnosis.json and the extended campaign manifest), then the
extended model rerun for every flight (diagnosis/extended/<flight>.json)."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import diagnose_campaign, extended_runs

#: The rule's params that the diagnosis takes (the others are the reruns').
DIAGNOSIS_KEYS = ("alpha", "max_causes", "min_gain", "atmosphere", "bootstrap")

sm = snakemake  # noqa: F821 (snakemake is injected)
p = sm.params
with logged(sm.log[0]):
    diagnose_campaign(sm.input.manifest, list(sm.input.measured), list(sm.input.forward), sm.output.json,
                      sm.output.manifest, platform_files=list(sm.input.platform),
                      reference_files=list(sm.input.reference), **{k: p[k] for k in DIAGNOSIS_KEYS})
    extended_runs(sm.output.manifest, dict(zip(p.flights, sm.output.extended, strict=True)), mast_l1=p.masts,
                  processing=p.processing, seeds=p.fresh_seeds, atmosphere=p.atmosphere)
