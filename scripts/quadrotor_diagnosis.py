"""Snakemake script: diagnosis of the single-law quadrotor model (quadrotor_diagnosis.json)."""

from dronewind.diagnose.quadrotor import diagnose_quadrotor_files
from dronewind.steps import logged

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    diagnose_quadrotor_files(sm.input.manifest, list(sm.input.windows), list(sm.input.blocks),
                             sm.input.runs[0] if len(sm.input.runs) else None, sm.output[0], sm.config)
