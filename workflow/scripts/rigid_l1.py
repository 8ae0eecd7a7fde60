"""Snakemake script: rigid-mount record L0 -> L1 (sonic and platform on one time axis, QC)."""

from dronewind.steps import logged
from dronewind.steps.payload import rigid_l1

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    # the flight's platform_log: one file, or none (an empty input)
    platform_log = list(sm.input.platform_log) if not isinstance(sm.input.platform_log, str) else [
        sm.input.platform_log]
    rigid_l1(sm.input.record, sm.output[0], platform_log=platform_log[0] if platform_log else None, **sm.params)
