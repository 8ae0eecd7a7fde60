# The paper's published numbers as data (config diagnosis.published): the forward model at the
# Table 4 conditions of every stationary sample, all mechanisms fitted to Table 5 and the
# Sect. 5.2/6 claims, the extended model rerun, the report.


if DIAGNOSIS["probe_jobs"] == "mechanism":

    # one job per sample and part (the baseline seeds, each mechanism's probes), joined
    rule published_probe:
        input:
            published=PUBLISHED,
        output:
            RESULTS / "published" / "forward" / "parts" / "{flight}" / "{part}.json",
        log:
            log_path("published_probe", "flight", "part"),
        benchmark:
            bench_path("published_probe", "flight", "part")
        priority: PRIORITY_FORWARD
        conda:
            ENV
        params:
            campaign=published_manifest,
            flight_id="{flight}",
            processing=CHAIN,
            seeds=PUBLISHED_SEEDS,
            part="{part}",
        script:
            "../../scripts/published_forward.py"

    rule published_forward:
        input:
            parts=expand(
                RESULTS
                / "published"
                / "forward"
                / "parts"
                / "{{flight}}"
                / "{part}.json",
                part=PROBE_PARTS,
            ),
        output:
            RESULTS / "published" / "forward" / "{flight}.json",
        log:
            log_path("published_forward", "flight"),
        benchmark:
            bench_path("published_forward", "flight")
        priority: PRIORITY_FORWARD
        conda:
            ENV
        script:
            "../../scripts/merge_forward.py"

else:

    rule published_forward:
        input:
            published=PUBLISHED,
        output:
            RESULTS / "published" / "forward" / "{flight}.json",
        log:
            log_path("published_forward", "flight"),
        benchmark:
            bench_path("published_forward", "flight")
        priority: PRIORITY_FORWARD
        conda:
            ENV
        params:
            campaign=published_manifest,
            flight_id="{flight}",
            processing=CHAIN,
            seeds=PUBLISHED_SEEDS,
        script:
            "../../scripts/published_forward.py"


rule published_diagnosis:
    input:
        published=PUBLISHED,
        forward=expand(
            RESULTS / "published" / "forward" / "{flight}.json",
            flight=PUBLISHED_FLIGHTS,
        ),
    output:
        RESULTS / "published" / "diagnosis.json",
    log:
        log_path("published_diagnosis"),
    benchmark:
        bench_path("published_diagnosis")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        alpha=DIAGNOSIS["alpha"],
        max_causes=DIAGNOSIS["max_causes"],
    script:
        "../../scripts/published_diagnosis.py"


rule published_rerun:
    input:
        published=PUBLISHED,
        diagnosis=RESULTS / "published" / "diagnosis.json",
    output:
        RESULTS / "published" / "rerun" / "{flight}.json",
    log:
        log_path("published_rerun", "flight"),
    benchmark:
        bench_path("published_rerun", "flight")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        campaign=published_manifest,
        flight_id="{flight}",
        processing=CHAIN,
        seeds=fresh_seeds(PUBLISHED_SEEDS),
    script:
        "../../scripts/published_rerun.py"


rule published_report:
    input:
        published=PUBLISHED,
        diagnosis=RESULTS / "published" / "diagnosis.json",
        rerun=expand(
            RESULTS / "published" / "rerun" / "{flight}.json", flight=PUBLISHED_FLIGHTS
        ),
    output:
        md=RESULTS / "published" / "report.md",
        json=RESULTS / "published" / "before_after.json",
        png=report(
            RESULTS / "figures" / "published_before_after.png",
            caption=report_caption("published_before_after"),
            category="Diagnosis",
            subcategory="Published numbers",
        ),
        pdf=RESULTS / "figures" / "published_before_after.pdf",
    log:
        log_path("published_report"),
    benchmark:
        bench_path("published_report")
    conda:
        ENV
    script:
        "../../scripts/published_report.py"
