# Mast L1 -> L2: the reference sonic over each flight's hover window.


rule mast_l2:
    input:
        mast=reference_of,
        drone=RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
    output:
        RESULTS / "netcdf" / "L2" / "{flight}_mast.nc",
    log:
        log_path("mast_l2", "flight"),
    benchmark:
        bench_path("mast_l2", "flight")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        campaign=CAMPAIGN.name,
        flight_id="{flight}",
        reference=reference_sonic,
        drone_mast=PROCESSING["drone_mast"],
    script:
        "../../scripts/mast_l2.py"
