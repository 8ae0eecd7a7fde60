"""Snakemake script: diagnosis.json of a campaign with rigid-mount flights only."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import rigid_diagnosis

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    rigid_diagnosis(sm.input.manifest, list(sm.input.platform), sm.output.json)
