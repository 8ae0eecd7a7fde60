# L2 -> L3 (mast cut to the flight, alignment, decimation, rotation) and L3 -> L4 (statistics, spectra, ...).


# The reference mast cut to a rigid-mount flight's hover window (mast L2) and the flight's L3
# (alignment, decimation, rotation) in one job; a payload flight's are made by its chain's job
# (payload_chain).
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
        flight=_alternatives(RIGID_MAST_FLIGHTS),
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


# The L4 of every flight's drone and reference mast in one job: a flight's L4 is a few tenths
# of a CPU-s of work where a job starts in about 1 CPU-s, and only campaign-level steps (flight
# statistics, tables, figures, report) read the L4 files, which rerun whenever any of them changes.
rule l4:
    input:
        l3=expand(RESULTS / "netcdf" / "L3" / "{flight}.nc", flight=MAST_FLIGHTS),
    output:
        drone=expand(
            RESULTS / "netcdf" / "L4" / "{flight}_drone.nc", flight=MAST_FLIGHTS
        ),
        mast=expand(RESULTS / "netcdf" / "L4" / "{flight}_mast.nc", flight=MAST_FLIGHTS),
    log:
        log_path("l4"),
    benchmark:
        bench_path("l4")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        flights=MAST_FLIGHTS,
        references={f: reference_sonic_of(f) for f in MAST_FLIGHTS},
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
