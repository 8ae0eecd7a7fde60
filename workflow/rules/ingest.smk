# L0 -> L1: raw records to UTC, CF NetCDF with range/spike/gap QC flags (payload flights: on to L3).


# A payload flight's chain in one job, each step cheap beside a job's start-up: sonic and INS to
# L1 and on to L2 (the hover window, the sonic-INS lag and the motion correction, Ghirardelli et
# al. 2025, Sect. 3), the reference mast cut to the hover (mast L2) and the L3 (alignment,
# decimation, rotation). Every later step of the flight reads its L3, so a change of any of these
# steps reruns the same jobs as when they were apart.
rule payload_chain:
    input:
        sonic=payload_file("sonic"),
        ins=payload_file("ins"),
        mast=reference_of,
    output:
        sonic=RESULTS / "netcdf" / "L1" / "{flight}_sonic.nc",
        ins=RESULTS / "netcdf" / "L1" / "{flight}_ins.nc",
        drone=RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
        mast=RESULTS / "netcdf" / "L2" / "{flight}_mast.nc",
        l3=RESULTS / "netcdf" / "L3" / "{flight}.nc",
    log:
        log_path("payload_chain", "flight"),
    benchmark:
        bench_path("payload_chain", "flight")
    wildcard_constraints:
        flight=_alternatives(PAYLOAD_FLIGHTS),
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=400,
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
        flight=flight_entry,
        sonic_ins_lag=PROCESSING["sonic_ins_lag"],
        hover=PROCESSING["hover"],
        max_missing_fraction=PROCESSING["max_missing_fraction"],
        reference=reference_sonic,
        drone_mast=PROCESSING["drone_mast"],
        rotation=PROCESSING["rotation"],
    script:
        "../scripts/payload_chain.py"


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
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        sonic=mast_sonic,
        despike=PROCESSING["despike"],
        simulated=CAMPAIGN.simulated,
        data_root=str(L0),
        attribution=ATTRIBUTION,
    script:
        "../scripts/mast_l1.py"
