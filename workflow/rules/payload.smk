# L1 -> L2 for the payload: hover window, sonic-INS lag, motion correction (seed 000, Sect. 3).


rule payload_l2:
    input:
        manifest=str(CAMPAIGN.path),
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
    script:
        "../../scripts/payload_l2.py"
