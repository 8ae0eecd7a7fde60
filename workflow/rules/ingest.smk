# L0 -> L1: raw records to UTC, CF NetCDF with range/spike/gap QC flags.


rule payload_l1:
    input:
        sonic=payload_file("sonic"),
        ins=payload_file("ins"),
    output:
        sonic=RESULTS / "netcdf" / "L1" / "{flight}_sonic.nc",
        ins=RESULTS / "netcdf" / "L1" / "{flight}_ins.nc",
    log:
        log_path("payload_l1", "flight"),
    benchmark:
        bench_path("payload_l1", "flight")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        site=SITE,
        target_height_m=target_height,
        despike=PROCESSING["despike"],
        simulated=CAMPAIGN.simulated,
        data_root=str(L0),
        sonic_format=payload_format("sonic"),
        ins_format=payload_format("ins"),
        attribution=ATTRIBUTION,
    script:
        "../../scripts/payload_l1.py"


rule mast_l1:
    input:
        files=lambda wc: mast_files(wc.sonic),
    output:
        RESULTS / "netcdf" / "L1" / "mast_{sonic}.nc",
    log:
        log_path("mast_l1", "sonic"),
    benchmark:
        bench_path("mast_l1", "sonic")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        campaign=CAMPAIGN.name,
        sonic=mast_sonic,
        despike=PROCESSING["despike"],
        simulated=CAMPAIGN.simulated,
        data_root=str(L0),
        attribution=ATTRIBUTION,
    script:
        "../../scripts/mast_l1.py"
