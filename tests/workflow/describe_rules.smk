# The workflow's rules as Snakemake registered them, written as JSON to $DESCRIBE_RULES_JSON:
# name, log, benchmark, conda environment, threads and resources of every rule. Used by
# tests/workflow/test_workflow.py (`snakemake --snakefile tests/workflow/describe_rules.smk --list-rules`).
import json
import os


include: "../../Snakefile"


with open(os.environ["DESCRIBE_RULES_JSON"], "w") as _out:
    json.dump(
        [
            {
                "name": _rule.name,
                "log": len(_rule.log) > 0,
                "benchmark": _rule.benchmark is not None,
                "conda": _rule.conda_env is not None,
                "threads": str(_rule.resources.get("_cores")),
                "resources": sorted(
                    k for k in _rule.resources if not k.startswith("_")
                ),
                "script": str(_rule.script),
            }
            for _rule in workflow.rules
        ],
        _out,
    )
