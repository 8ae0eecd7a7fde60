# L2 -> L3 (mast cut to the flight, alignment, decimation, rotation) and L3 -> L4 (statistics, spectra, ...).


# The reference mast cut to a flight's hover window (mast L2) and the flight's L3 (alignment,
# decimation, rotation) in one job.
rule l3:
    input:
        drone=RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
        mast=reference_of,
    output:
        mast=RESULTS / "netcdf" / "L2" / "{flight}_mast.nc",
        l3=RESULTS / "netcdf" / "L3" / "{flight}.nc",
    log:
        log_path("l3", "flight"),
    benchmark:
        bench_path("l3", "flight")
    wildcard_constraints:
        flight=_alternatives(PAYLOAD_FLIGHTS + RIGID_MAST_FLIGHTS),
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=400,
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        flight=flight_entry,
        reference=reference_sonic,
        drone_mast=PROCESSING["drone_mast"],
        rotation=PROCESSING["rotation"],
    script:
        "../scripts/l3.py"


# A flight without a reference mast (rigid mount): drone-only L3 (streamline coordinates at
# the L2 rate) and drone L4; its flight_stats row has the mast columns empty.
rule drone_l3:
    input:
        drone=RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
    output:
        RESULTS / "netcdf" / "L3" / "{flight}.nc",
    log:
        log_path("drone_l3", "flight"),
    benchmark:
        bench_path("drone_l3", "flight")
    wildcard_constraints:
        flight=_alternatives(DRONE_ONLY_FLIGHTS),
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        flight=flight_entry,
        site=SITE,
        rotation=PROCESSING["rotation"],
    script:
        "../scripts/drone_l3.py"


rule l4_drone_only:
    input:
        l3=RESULTS / "netcdf" / "L3" / "{flight}.nc",
    output:
        RESULTS / "netcdf" / "L4" / "{flight}_drone.nc",
    log:
        log_path("l4_drone_only", "flight"),
    benchmark:
        bench_path("l4_drone_only", "flight")
    wildcard_constraints:
        flight=_alternatives(DRONE_ONLY_FLIGHTS),
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        sensor="drone",
        reference=None,
        site=SITE,
        spectra=PROCESSING["spectra"],
        quadrant=PROCESSING["quadrant"],
        detrending=PROCESSING["detrending"],
    script:
        "../scripts/l4.py"


# the L4 of a flight's drone and reference mast in one job (two files)
rule l4:
    input:
        l3=RESULTS / "netcdf" / "L3" / "{flight}.nc",
    output:
        drone=RESULTS / "netcdf" / "L4" / "{flight}_drone.nc",
        mast=RESULTS / "netcdf" / "L4" / "{flight}_mast.nc",
    log:
        log_path("l4", "flight"),
    benchmark:
        bench_path("l4", "flight")
    wildcard_constraints:
        flight=_alternatives(PAYLOAD_FLIGHTS + RIGID_MAST_FLIGHTS),
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        reference=reference_sonic,
        spectra=PROCESSING["spectra"],
        quadrant=PROCESSING["quadrant"],
        detrending=PROCESSING["detrending"],
    script:
        "../scripts/l4_flight.py"


rule flight_stats:
    input:
        [
            str(RESULTS / "netcdf" / "L4" / f"{flight}_{sensor}.nc")
            for flight in PAYLOAD_FLIGHTS + RIGID_FLIGHTS
            for sensor in flight_sensors(flight)
        ],
    output:
        RESULTS / "tables" / "flight_stats.csv",
    log:
        log_path("flight_stats"),
    benchmark:
        bench_path("flight_stats")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    script:
        "../scripts/flight_stats.py"
