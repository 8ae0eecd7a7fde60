# dronewind: drone-borne wind and turbulence validated against mast sonics.
# Stages live in workflow/rules/; config is validated in workflow/rules/common.smk.


configfile: "config/config.yaml"


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/simulate.smk"
include: "workflow/rules/ingest.smk"
include: "workflow/rules/payload.smk"
include: "workflow/rules/mast.smk"
include: "workflow/rules/analysis.smk"
include: "workflow/rules/blocks.smk"
include: "workflow/rules/quadrotor.smk"
include: "workflow/rules/autopilot.smk"
include: "workflow/rules/tunnel.smk"
include: "workflow/rules/diagnose.smk"
include: "workflow/rules/report.smk"


if PUBLISHED:

    include: "workflow/rules/published.smk"


rule all:
    default_target: True
    input:
        all_outputs(),
