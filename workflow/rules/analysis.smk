# L2 -> L3 (alignment, decimation, rotation) and L3 -> L4 (statistics, spectra, ...).


rule l3:
    input:
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
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        flight=flight_entry,
        reference=reference_sonic,
        drone_mast=PROCESSING["drone_mast"],
        rotation=PROCESSING["rotation"],
    script:
        "../../scripts/l3.py"


rule l4:
    input:
        l3=RESULTS / "netcdf" / "L3" / "{flight}.nc",
    output:
        RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc",
    log:
        log_path("l4", "flight", "sensor"),
    benchmark:
        bench_path("l4", "flight", "sensor")
    conda:
        ENV
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        sensor="{sensor}",
        reference=reference_sonic,
        spectra=PROCESSING["spectra"],
        quadrant=PROCESSING["quadrant"],
        detrending=PROCESSING["detrending"],
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
