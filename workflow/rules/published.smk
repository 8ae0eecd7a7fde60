# The paper's published numbers as data (config diagnosis.published): the forward model at the
# Table 4 conditions of every stationary sample, all mechanisms fitted to Table 5 and the
# Sect. 5.2/6 claims, the extended model rerun, the report.


# The forward runs of a published sample: one job per sample, or one per sample and part
# joined by published_forward_parts (diagnosis.probe_jobs, as for the campaign's flights).
PUBLISHED_INPUT = [PUBLISHED] if PUBLISHED else []


rule published_forward:
    input:
        published=PUBLISHED_INPUT,
    output:
        RESULTS / "published" / "forward" / "{flight}.json",
    log:
        log_path("published_forward", "flight"),
    benchmark:
        bench_path("published_forward", "flight")
    wildcard_constraints:
        flight=only_if(FORWARD_BY_FLIGHT, PUBLISHED_FLIGHTS),
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=700,
    params:
        campaign=published_manifest,
        flight_id="{flight}",
        processing=CHAIN,
        seeds=PUBLISHED_SEEDS,
    script:
        "../scripts/published_forward.py"


rule published_probe:
    input:
        published=PUBLISHED_INPUT,
    output:
        RESULTS / "published" / "forward" / "parts" / "{flight}" / "{part}.json",
    log:
        log_path("published_probe", "flight", "part"),
    benchmark:
        bench_path("published_probe", "flight", "part")
    wildcard_constraints:
        flight=only_if(not FORWARD_BY_FLIGHT, PUBLISHED_FLIGHTS),
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=700,
    params:
        campaign=published_manifest,
        flight_id="{flight}",
        processing=CHAIN,
        seeds=PUBLISHED_SEEDS,
        part="{part}",
    script:
        "../scripts/published_forward.py"


rule published_forward_parts:
    input:
        parts=expand(
            RESULTS / "published" / "forward" / "parts" / "{{flight}}" / "{part}.json",
            part=PROBE_PARTS,
        ),
    output:
        RESULTS / "published" / "forward" / "{flight}.json",
    log:
        log_path("published_forward_parts", "flight"),
    benchmark:
        bench_path("published_forward_parts", "flight")
    wildcard_constraints:
        flight=only_if(not FORWARD_BY_FLIGHT, PUBLISHED_FLIGHTS),
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    script:
        "../scripts/merge_forward.py"


# Every mechanism fitted to the published numbers, then the extended model rerun for every
# sample in the same job (a sample's rerun is a few forward runs, about 0.5 CPU-s).
rule published_diagnosis:
    input:
        published=PUBLISHED_INPUT,
        forward=expand(
            RESULTS / "published" / "forward" / "{flight}.json",
            flight=PUBLISHED_FLIGHTS,
        ),
    output:
        json=RESULTS / "published" / "diagnosis.json",
        rerun=expand(
            RESULTS / "published" / "rerun" / "{flight}.json", flight=PUBLISHED_FLIGHTS
        ),
    log:
        log_path("published_diagnosis"),
    benchmark:
        bench_path("published_diagnosis")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=800,
    params:
        alpha=DIAGNOSIS["alpha"],
        max_causes=DIAGNOSIS["max_causes"],
        flights=PUBLISHED_FLIGHTS,
        campaigns={f: published_manifest_of(f) for f in PUBLISHED_FLIGHTS},
        processing=CHAIN,
        seeds=fresh_seeds(PUBLISHED_SEEDS),
    script:
        "../scripts/published_diagnosis.py"


rule published_report:
    input:
        published=PUBLISHED_INPUT,
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
    threads: 1
    resources:
        mem_mb=300,
    script:
        "../scripts/published_report.py"
