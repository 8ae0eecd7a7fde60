# L1 -> L2 for the payload: hover window, sonic-INS lag, motion correction (seed 000, Sect. 3).


rule payload_l2:
    input:
        sonic=RESULTS / "netcdf" / "L1" / "{flight}_sonic.nc",
        ins=RESULTS / "netcdf" / "L1" / "{flight}_ins.nc",
    output:
        RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
    log:
        log_path("payload_l2", "flight"),
    benchmark:
        bench_path("payload_l2", "flight")
    conda:
        ENV
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        flight=flight_entry,
        site=SITE,
        sonic_ins_lag=PROCESSING["sonic_ins_lag"],
        hover=PROCESSING["hover"],
        max_missing_fraction=PROCESSING["max_missing_fraction"],
    script:
        "../../scripts/payload_l2.py"
