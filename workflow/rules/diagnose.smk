# What the simulation gets wrong: features per flight, forward-model probes per flight,
# the campaign diagnosis, the extended model rerun per flight, and the report. The forward
# runs read the reference mast's L1: with diagnosis.atmosphere: measured it is their
# atmosphere (dronewind.diagnose.forward_atmosphere.atmosphere_record).


rule diagnose_measured:
    input:
        sonic=RESULTS / "netcdf" / "L1" / "{flight}_sonic.nc",
        ins=RESULTS / "netcdf" / "L1" / "{flight}_ins.nc",
        drone=RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
        l3=RESULTS / "netcdf" / "L3" / "{flight}.nc",
    output:
        RESULTS / "diagnosis" / "measured" / "{flight}.json",
    log:
        log_path("diagnose_measured", "flight"),
    benchmark:
        bench_path("diagnose_measured", "flight")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        campaign=flight_manifest,
        flight_id="{flight}",
        sonic_ins_lag=PROCESSING["sonic_ins_lag"],
        hover=PROCESSING["hover"],
        max_missing_fraction=PROCESSING["max_missing_fraction"],
    script:
        "../../scripts/diagnose_measured.py"


if DIAGNOSIS["probe_jobs"] == "mechanism":

    # one job per flight and part (the baseline seeds, each mechanism's probes), joined
    rule diagnose_probe:
        input:
            measured=RESULTS / "diagnosis" / "measured" / "{flight}.json",
            mast=reference_of,
        output:
            RESULTS / "diagnosis" / "forward" / "parts" / "{flight}" / "{part}.json",
        log:
            log_path("diagnose_probe", "flight", "part"),
        benchmark:
            bench_path("diagnose_probe", "flight", "part")
        priority: PRIORITY_FORWARD
        conda:
            ENV
        params:
            campaign=flight_manifest,
            flight_id="{flight}",
            processing=CHAIN,
            seeds=DIAGNOSIS["seeds"],
            atmosphere=DIAGNOSIS["atmosphere"],
            part="{part}",
        script:
            "../../scripts/diagnose_forward.py"

    rule diagnose_forward:
        input:
            parts=expand(
                RESULTS
                / "diagnosis"
                / "forward"
                / "parts"
                / "{{flight}}"
                / "{part}.json",
                part=PROBE_PARTS,
            ),
        output:
            RESULTS / "diagnosis" / "forward" / "{flight}.json",
        log:
            log_path("diagnose_forward", "flight"),
        benchmark:
            bench_path("diagnose_forward", "flight")
        priority: PRIORITY_FORWARD
        conda:
            ENV
        script:
            "../../scripts/merge_forward.py"

else:

    rule diagnose_forward:
        input:
            measured=RESULTS / "diagnosis" / "measured" / "{flight}.json",
            mast=reference_of,
        output:
            RESULTS / "diagnosis" / "forward" / "{flight}.json",
        log:
            log_path("diagnose_forward", "flight"),
        benchmark:
            bench_path("diagnose_forward", "flight")
        priority: PRIORITY_FORWARD
        conda:
            ENV
        params:
            campaign=flight_manifest,
            flight_id="{flight}",
            processing=CHAIN,
            seeds=DIAGNOSIS["seeds"],
            atmosphere=DIAGNOSIS["atmosphere"],
        script:
            "../../scripts/diagnose_forward.py"


rule diagnose:
    input:
        manifest=str(CAMPAIGN.path),
        measured=expand(
            RESULTS / "diagnosis" / "measured" / "{flight}.json",
            flight=PAYLOAD_FLIGHTS,
        ),
        forward=expand(
            RESULTS / "diagnosis" / "forward" / "{flight}.json", flight=PAYLOAD_FLIGHTS
        ),
        platform=expand(
            RESULTS / "diagnosis" / "platform" / "{flight}.json", flight=RIGID_FLIGHTS
        ),
    output:
        json=RESULTS / "diagnosis.json",
        manifest=RESULTS / "diagnosis" / "extended_campaign.yaml",
    log:
        log_path("diagnose"),
    benchmark:
        bench_path("diagnose")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        alpha=DIAGNOSIS["alpha"],
        max_causes=DIAGNOSIS["max_causes"],
        min_gain=DIAGNOSIS["min_gain"],
        atmosphere=DIAGNOSIS["atmosphere"],
        bootstrap=DIAGNOSIS["bootstrap"],
    script:
        "../../scripts/diagnose.py"


# Rigid-mount flights: the platform-motion response (platform_velocity_response) of each
# flight from its commanded motion over the whole record (L1), without a mast
# (dronewind.diagnose.platform_commanded); the L2 hover's spectral estimate for reference.


rule diagnose_platform:
    input:
        drone=RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
        l1=RESULTS / "netcdf" / "L1" / "{flight}_rigid.nc",
    output:
        RESULTS / "diagnosis" / "platform" / "{flight}.json",
    log:
        log_path("diagnose_platform", "flight"),
    benchmark:
        bench_path("diagnose_platform", "flight")
    wildcard_constraints:
        flight=_alternatives(RIGID_FLIGHTS),
    conda:
        ENV
    params:
        flight_id="{flight}",
        alpha=DIAGNOSIS["alpha"],
        segment_s=DIAGNOSIS["platform"]["segment_s"],
        band_factor=DIAGNOSIS["platform"]["band_factor"],
        flight=flight_entry,
        max_lag_s=PROCESSING["rigid_mount"]["max_lag_s"],
    script:
        "../../scripts/diagnose_platform.py"


if RIGID_FLIGHTS and not PAYLOAD_FLIGHTS:

    # a campaign without sling-load flights: diagnosis.json holds the rigid flights' results
    rule diagnose_rigid:
        input:
            manifest=str(CAMPAIGN.path),
            platform=expand(
                RESULTS / "diagnosis" / "platform" / "{flight}.json",
                flight=RIGID_FLIGHTS,
            ),
        output:
            json=RESULTS / "diagnosis.json",
        log:
            log_path("diagnose_rigid"),
        benchmark:
            bench_path("diagnose_rigid")
        conda:
            ENV
        script:
            "../../scripts/rigid_diagnosis.py"

    ruleorder: diagnose_rigid > diagnose


rule diagnose_extended:
    input:
        manifest=RESULTS / "diagnosis" / "extended_campaign.yaml",
        mast=reference_of,
    output:
        RESULTS / "diagnosis" / "extended" / "{flight}.json",
    log:
        log_path("diagnose_extended", "flight"),
    benchmark:
        bench_path("diagnose_extended", "flight")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        flight_id="{flight}",
        processing=CHAIN,
        seeds=fresh_seeds(DIAGNOSIS["seeds"]),
        atmosphere=DIAGNOSIS["atmosphere"],
    script:
        "../../scripts/diagnose_extended.py"


rule diagnosis_report:
    input:
        diagnosis=RESULTS / "diagnosis.json",
        measured=expand(
            RESULTS / "diagnosis" / "measured" / "{flight}.json",
            flight=PAYLOAD_FLIGHTS,
        ),
        forward=expand(
            RESULTS / "diagnosis" / "forward" / "{flight}.json", flight=PAYLOAD_FLIGHTS
        ),
        extended=expand(
            RESULTS / "diagnosis" / "extended" / "{flight}.json",
            flight=PAYLOAD_FLIGHTS,
        ),
    output:
        md=RESULTS / "diagnosis" / "report.md",
        csv=RESULTS / "diagnosis" / "residuals.csv",
        png=report(
            RESULTS / "figures" / "diagnosis_residuals.png",
            caption=report_caption("diagnosis_residuals"),
            category="Diagnosis",
            subcategory="Campaign diagnosis",
        ),
        pdf=RESULTS / "figures" / "diagnosis_residuals.pdf",
        spectra_png=report(
            RESULTS / "figures" / "diagnosis_spectra.png",
            caption=report_caption("diagnosis_spectra"),
            category="Diagnosis",
            subcategory="Campaign diagnosis",
        ),
        spectra_pdf=RESULTS / "figures" / "diagnosis_spectra.pdf",
    log:
        log_path("diagnosis_report"),
    benchmark:
        bench_path("diagnosis_report")
    conda:
        ENV
    script:
        "../../scripts/diagnosis_report.py"
