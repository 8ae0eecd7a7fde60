"""Snakemake script: one quadrotor flight, L1 -> calibrated 1 Hz wind (L2) per UAV."""

from dronewind.steps import logged
from dronewind.steps.quadrotor import quadrotor_l2

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    uavs = list(sm.params.uavs)
    quadrotor_l2(sm.input.manifest, sm.params.flight, dict(zip(uavs, sm.input.l1, strict=True)),
                 sm.input.calibration, sm.input.summary, dict(zip(uavs, sm.output.l2, strict=True)), sm.config)
