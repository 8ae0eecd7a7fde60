"""Snakemake script: join the per-part forward-model runs of one flight (diagnosis.probe_jobs: mechanism)."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import merge_forward_parts

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    merge_forward_parts(sm.input.parts, sm.output[0])
