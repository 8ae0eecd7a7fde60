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


rule l4:
    input:
        manifest=str(CAMPAIGN.path),
        l3=RESULTS / "netcdf" / "L3" / "{flight}.nc",
    output:
        RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc",
    log:
        log_path("l4", "flight", "sensor"),
    benchmark:
        bench_path("l4", "flight", "sensor")
    conda:
        ENV
    script:
        "../../scripts/l4.py"


rule flight_stats:
    input:
        expand(
            RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc",
            flight=PAYLOAD_FLIGHTS,
            sensor=["drone", "mast"],
        ),
    output:
        RESULTS / "tables" / "flight_stats.csv",
    log:
        log_path("flight_stats"),
    benchmark:
        bench_path("flight_stats")
    conda:
        ENV
    script:
        "../../scripts/flight_stats.py"
