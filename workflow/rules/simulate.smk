# The virtual campaign: raw (L0) files written by the simulator, one job per flight.
# Only for manifests with a `simulation:` section; measured campaigns skip this stage.


if CAMPAIGN.simulated:
    for _flight in PAYLOAD_FLIGHTS:

        rule:
            name:
                f"simulate_payload_{_flight}"
            output:
                **simulated_payload_outputs(_flight),
            log:
                str(RESULTS / "logs" / "simulate_payload" / f"{_flight}.log"),
            benchmark:
                str(RESULTS / "benchmarks" / "simulate_payload" / f"{_flight}.tsv")
            priority: PRIORITY_CHAIN
            conda:
                ENV
            params:
                campaign=SIMULATION,
                flight_id=_flight,
                manifest_dir=str(CAMPAIGN.directory),
                out_dir=l0_root,
            script:
                "../../scripts/simulate_payload.py"
