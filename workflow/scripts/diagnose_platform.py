"""Snakemake script: platform-motion response of one rigid-mount flight (diagnosis/platform/<flight>.json)."""

from dronewind.steps import logged
from dronewind.steps.diagnosis import platform_diagnosis

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    platform_diagnosis(sm.input.drone, sm.output[0], rigid_l1=sm.input.l1, **sm.params)
