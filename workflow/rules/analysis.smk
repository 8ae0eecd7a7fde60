# L2 -> L3 (alignment, decimation, rotation) and L3 -> L4 (statistics, spectra, ...).


rule l3:
    input:
        manifest=str(CAMPAIGN.path),
        drone=RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
        mast=RESULTS / "netcdf" / "L2" / "{flight}_mast.nc",
    output:
        RESULTS / "netcdf" / "L3" / "{flight}.nc",
    log:
        log_path("l3", "flight"),
    benchmark:
        bench_path("l3", "flight")
    conda:
        ENV
    script:
        "../../scripts/l3.py"
