# Campaign-level records, tables, figures and the HTML report.


rule campaign_record:
    """Record the validated manifest (normalised) with its checksum and the config hash."""
    input:
        manifest=str(CAMPAIGN.path),
    output:
        RESULTS / "campaign.json",
    log:
        log_path("campaign_record"),
    benchmark:
        bench_path("campaign_record")
    conda:
        ENV
    script:
        "../../scripts/campaign_record.py"
