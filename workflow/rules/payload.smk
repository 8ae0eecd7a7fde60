# L1 -> L2 for the payload: hover window, sonic-INS lag, motion correction (Ghirardelli et al. 2025, Sect. 3).


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
    wildcard_constraints:
        flight=_alternatives(PAYLOAD_FLIGHTS),
    priority: PRIORITY_CHAIN
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


# Rigid-mount multicopter flights: one record (sonic + platform) -> L1 -> L2 (steady segment,
# sonic-platform lag at 1/fs, V = R M V_sensor + V_platform).


rule rigid_l1:
    input:
        record=rigid_record,
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
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        flight=flight_entry,
        site=SITE,
        despike=PROCESSING["despike"],
        data_root=str(L0),
        attribution=ATTRIBUTION,
    script:
        "../../scripts/rigid_l1.py"


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
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        flight=flight_entry,
        site=SITE,
        rigid_mount=PROCESSING["rigid_mount"],
        max_missing_fraction=PROCESSING["max_missing_fraction"],
    script:
        "../../scripts/rigid_l2.py"
