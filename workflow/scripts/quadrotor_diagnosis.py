"""Snakemake script: diagnosis of the single-law quadrotor model (quadrotor_diagnosis.json)."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_diagnosis

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    quadrotor_diagnosis(sm.params.campaign, list(sm.input.windows), list(sm.input.blocks),
                        sm.input.runs[0] if len(sm.input.runs) else None, sm.output[0], sm.params.alpha,
                        sm.params.min_gain, sm.params.window_s)
