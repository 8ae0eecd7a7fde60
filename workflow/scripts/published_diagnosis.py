"""Snakemake script: fit every mechanism to the paper's published numbers, then rerun every sample with
the extended model (fresh seeds)."""

from dronewind.steps import logged
from dronewind.steps.published import published_diagnosis, published_reruns

sm = snakemake  # noqa: F821 (snakemake is injected)
p = sm.params
with logged(sm.log[0]):
    published_diagnosis(sm.input.published[0], list(sm.input.forward), sm.output.json, alpha=p.alpha,
                        max_causes=p.max_causes)
    published_reruns(sm.input.published[0], sm.output.json, dict(zip(p.flights, sm.output.rerun, strict=True)),
                     campaigns=p.campaigns, processing=p.processing, seeds=p.seeds)
