# Rigid-mount multicopter flights, L0 -> L1 -> L2 (the payload's L1 and L2: ingest.smk).


# Rigid-mount multicopter flights: one record (sonic + platform) -> L1 -> L2 (steady segment,
# sonic-platform lag at 1/fs, V = R M V_sensor + V_platform). A flight with a platform_log takes
# the platform variables its record lacks from the vehicle's own log (an input: a changed log
# reruns the L1).


rule rigid_l1:
    input:
        record=rigid_record,
        platform_log=rigid_platform_log,
    output:
        RESULTS / "netcdf" / "L1" / "{flight}_rigid.nc",
    log:
        log_path("rigid_l1", "flight"),
    benchmark:
        bench_path("rigid_l1", "flight")
    wildcard_constraints:
        flight=_alternatives(RIGID_FLIGHTS),
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=200,
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        flight=flight_entry,
        site=SITE,
        despike=PROCESSING["despike"],
        data_root=str(L0),
        attribution=ATTRIBUTION,
    script:
        "../scripts/rigid_l1.py"


rule rigid_l2:
    input:
        l1=RESULTS / "netcdf" / "L1" / "{flight}_rigid.nc",
    output:
        RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
    log:
        log_path("rigid_l2", "flight"),
    benchmark:
        bench_path("rigid_l2", "flight")
    wildcard_constraints:
        flight=_alternatives(RIGID_FLIGHTS),
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
        rigid_mount=PROCESSING["rigid_mount"],
        max_missing_fraction=PROCESSING["max_missing_fraction"],
    script:
        "../scripts/rigid_l2.py"
