# dronewind: drone-borne wind and turbulence validated against mast sonics.
# Stages live in workflow/rules/; config is validated in workflow/rules/common.smk.
# Jobs, resources, profiles and the results lock: docs/workflow.md.
import sys

from dronewind.steps.lock import acquire_results_lock, release_results_lock


configfile: "config/config.yaml"


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/simulate.smk"
include: "workflow/rules/ingest.smk"
include: "workflow/rules/payload.smk"
include: "workflow/rules/analysis.smk"
include: "workflow/rules/blocks.smk"
include: "workflow/rules/quadrotor.smk"
include: "workflow/rules/autopilot.smk"
include: "workflow/rules/tunnel.smk"
include: "workflow/rules/diagnose.smk"
include: "workflow/rules/report.smk"
include: "workflow/rules/published.smk"


# One run at a time on a results folder, across checkouts: a lock file under
# results/<name>/ (dronewind.steps.lock), taken when jobs are about to run (never in a dry
# run) and released at the end. A lock left by a killed run is taken over, so an interrupted
# run is resumed by running the same command again (the default profile sets nolock:
# Snakemake's own lock, in .snakemake/ of the checkout, would need --unlock after kill -9).
onstart:
    if workflow.is_main_process:
        _note = acquire_results_lock(RESULTS, workflow.basedir)
        if _note:
            print(_note, file=sys.stderr)


onsuccess:
    if workflow.is_main_process:
        release_results_lock(RESULTS)


onerror:
    if workflow.is_main_process:
        release_results_lock(RESULTS)


rule all:
    default_target: True
    input:
        all_outputs(),
