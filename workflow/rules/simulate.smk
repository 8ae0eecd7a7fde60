# The virtual campaign: raw (L0) files of the payload flights written by the simulator, one job
# per flight. Only for manifests with a `simulation:` section: for a measured campaign the
# rule's wildcard matches no flight.


rule simulate_payload:
    output:
        **simulated_payload_patterns(),
    log:
        log_path("simulate_payload", "flight"),
    benchmark:
        bench_path("simulate_payload", "flight")
    wildcard_constraints:
        flight=only_if(CAMPAIGN.simulated, PAYLOAD_FLIGHTS),
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=500,
    params:
        campaign=SIMULATION,
        flight_id="{flight}",
        manifest_dir=str(CAMPAIGN.directory),
        out_dir=l0_root,
    script:
        "../scripts/simulate_payload.py"
