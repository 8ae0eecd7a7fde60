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
    params:
        config=canonical(config),
    script:
        "../../scripts/campaign_record.py"


rule tables:
    input:
        expand(
            RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc",
            flight=PAYLOAD_FLIGHTS,
            sensor=["drone", "mast"],
        ),
    output:
        multiext(str(RESULTS / "tables" / "table4_flights"), ".csv", ".md", ".tex"),
        multiext(str(RESULTS / "tables" / "table5_statistics"), ".csv", ".md", ".tex"),
    log:
        log_path("tables"),
    benchmark:
        bench_path("tables")
    conda:
        ENV
    script:
        "../../scripts/tables.py"


rule figures:
    input:
        l2=expand(
            RESULTS / "netcdf" / "L2" / "{flight}_drone.nc", flight=PAYLOAD_FLIGHTS
        ),
        l3=expand(RESULTS / "netcdf" / "L3" / "{flight}.nc", flight=PAYLOAD_FLIGHTS),
        l4=expand(
            RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc",
            flight=PAYLOAD_FLIGHTS,
            sensor=["drone", "mast"],
        ),
        campaign=RESULTS / "campaign.json",
    output:
        png=[
            report(
                str(RESULTS / "figures" / f"{name}.png"),
                caption=f"../report/{name}.rst",
                category="Payload validation",
            )
            for name in FIGURES
        ],
        pdf=[str(RESULTS / "figures" / f"{name}.pdf") for name in FIGURES],
    log:
        log_path("figures"),
    benchmark:
        bench_path("figures")
    conda:
        ENV
    script:
        "../../scripts/figures.py"
