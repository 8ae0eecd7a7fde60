"""Snakemake script: simulate one payload flight (sonic, INS and mast TOA5 files)."""

from dronewind.steps import logged, simulate_payload

with logged(snakemake.log[0]):  # noqa: F821 (snakemake is injected)
    simulate_payload(snakemake.input.manifest, snakemake.params.flight, snakemake.params.out_dir)  # noqa: F821
