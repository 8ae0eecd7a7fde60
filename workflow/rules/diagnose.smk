# What the simulation gets wrong: features per flight, forward-model probes per flight,
# the campaign diagnosis, the extended model rerun per flight, and the report. The forward
# runs read the reference mast's L1: with diagnosis.atmosphere: measured it is their
# atmosphere (dronewind.diagnose.forward_atmosphere.atmosphere_record).


# The forward-model runs of a flight: two jobs per flight (diagnosis.probe_jobs: flight, the
# default: diagnose_probes, the measured features, the first third of the baseline seeds and
# every probe, which reuse the first seed's products; then diagnose_forward, the other two
# thirds of the seeds, joined with the first job's runs), or one job per flight and part (the
# baseline seeds, each mechanism's probes) joined by diagnose_forward_parts (probe_jobs:
# mechanism). The wildcard of the other mode's rules matches no flight. Two jobs rather than
# one keep each within the first 15 s of its run, which Snakemake's benchmark samples every
# 0.5 s (later every 30 s), so that its benchmark file holds its whole CPU time.
FORWARD_BY_FLIGHT = DIAGNOSIS["probe_jobs"] == "flight"
# the parts of a flight's runs in its two jobs (dronewind.diagnose.probes.seed_part)
WITH_PROBES = [seed_part(1, 3)] + PROBE_PARTS[1:]
OTHER_SEEDS = [seed_part(2, 3), seed_part(3, 3)]
# the measured-features step's settings (dronewind.steps.diagnosis.measured_features)
MEASURED_PARAMS = dict(
    campaign=flight_manifest,
    flight_id="{flight}",
    sonic_ins_lag=PROCESSING["sonic_ins_lag"],
    hover=PROCESSING["hover"],
    max_missing_fraction=PROCESSING["max_missing_fraction"],
    forward_payload=DIAGNOSIS["forward_payload"],
)


# The residual features of a flight and the forward model's conditions (measured/{flight}.json):
# made by the flight's forward job (diagnose_forward) in the default mode, by a job of their own
# where the forward runs are split by mechanism.
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
    wildcard_constraints:
        flight=only_if(not FORWARD_BY_FLIGHT, PAYLOAD_FLIGHTS),
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=400,
    params:
        **MEASURED_PARAMS,
    script:
        "../scripts/diagnose_measured.py"


rule diagnose_probes:
    input:
        sonic=RESULTS / "netcdf" / "L1" / "{flight}_sonic.nc",
        ins=RESULTS / "netcdf" / "L1" / "{flight}_ins.nc",
        drone=RESULTS / "netcdf" / "L2" / "{flight}_drone.nc",
        l3=RESULTS / "netcdf" / "L3" / "{flight}.nc",
        mast=reference_of,
    output:
        measured=RESULTS / "diagnosis" / "measured" / "{flight}.json",
        probes=temp(
            RESULTS / "diagnosis" / "forward" / "parts" / "{flight}" / "probes.json"
        ),
    log:
        log_path("diagnose_probes", "flight"),
    benchmark:
        bench_path("diagnose_probes", "flight")
    wildcard_constraints:
        flight=only_if(FORWARD_BY_FLIGHT, PAYLOAD_FLIGHTS),
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=800,
    params:
        **MEASURED_PARAMS,
        processing=CHAIN,
        seeds=DIAGNOSIS["seeds"],
        atmosphere=DIAGNOSIS["atmosphere"],
        parts=WITH_PROBES,
    script:
        "../scripts/diagnose_probes.py"


rule diagnose_forward:
    input:
        measured=RESULTS / "diagnosis" / "measured" / "{flight}.json",
        probes=RESULTS / "diagnosis" / "forward" / "parts" / "{flight}" / "probes.json",
        mast=reference_of,
    output:
        RESULTS / "diagnosis" / "forward" / "{flight}.json",
    log:
        log_path("diagnose_forward", "flight"),
    benchmark:
        bench_path("diagnose_forward", "flight")
    wildcard_constraints:
        flight=only_if(FORWARD_BY_FLIGHT, PAYLOAD_FLIGHTS),
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=700,
    params:
        campaign=flight_manifest,
        flight_id="{flight}",
        processing=CHAIN,
        seeds=DIAGNOSIS["seeds"],
        atmosphere=DIAGNOSIS["atmosphere"],
        parts=OTHER_SEEDS,
    script:
        "../scripts/diagnose_forward.py"


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
    wildcard_constraints:
        flight=only_if(not FORWARD_BY_FLIGHT, PAYLOAD_FLIGHTS),
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=800,
    params:
        campaign=flight_manifest,
        flight_id="{flight}",
        processing=CHAIN,
        seeds=DIAGNOSIS["seeds"],
        atmosphere=DIAGNOSIS["atmosphere"],
        parts=lambda wc: [wc.part],
    script:
        "../scripts/diagnose_probe.py"


rule diagnose_forward_parts:
    input:
        parts=expand(
            RESULTS / "diagnosis" / "forward" / "parts" / "{{flight}}" / "{part}.json",
            part=PROBE_PARTS,
        ),
    output:
        RESULTS / "diagnosis" / "forward" / "{flight}.json",
    log:
        log_path("diagnose_forward_parts", "flight"),
    benchmark:
        bench_path("diagnose_forward_parts", "flight")
    wildcard_constraints:
        flight=only_if(not FORWARD_BY_FLIGHT, PAYLOAD_FLIGHTS),
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    script:
        "../scripts/merge_forward.py"


# The bootstrap reference of the campaign diagnosis in diagnosis.bootstrap_jobs parts, each a
# contiguous run of the one seeded sequence of replicates (dronewind.diagnose.naming.reference_part):
# joined in order they are the reference the diagnosis would draw itself. On 2 cores the parts
# run beside each other and beside the report's other long jobs; each stays within the first
# 15 s of its job, which Snakemake's benchmark samples every 0.5 s.
rule diagnose_reference:
    input:
        measured=expand(
            RESULTS / "diagnosis" / "measured" / "{flight}.json",
            flight=PAYLOAD_FLIGHTS,
        ),
        forward=expand(
            RESULTS / "diagnosis" / "forward" / "{flight}.json", flight=PAYLOAD_FLIGHTS
        ),
    output:
        temp(RESULTS / "diagnosis" / "reference" / "{part}.npz"),
    log:
        log_path("diagnose_reference", "part"),
    benchmark:
        bench_path("diagnose_reference", "part")
    wildcard_constraints:
        part=_alternatives(REFERENCE_PARTS),
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        bootstrap=DIAGNOSIS["bootstrap"],
        part=lambda wc: int(wc.part),
        parts=len(REFERENCE_PARTS),
    script:
        "../scripts/diagnose_reference.py"


# The campaign diagnosis, then the extended model (named causes at their fitted values, fresh
# seeds) rerun for every flight in the same job: a flight's rerun is a few forward runs (about
# 0.3 CPU-s) where a job starts in about 1 CPU-s, and all of them read what the diagnosis wrote.
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
        reference=expand(
            RESULTS / "diagnosis" / "reference" / "{part}.npz", part=REFERENCE_PARTS
        ),
        masts=sorted({reference_l1(f) for f in PAYLOAD_FLIGHTS}),
    output:
        json=RESULTS / "diagnosis.json",
        manifest=RESULTS / "diagnosis" / "extended_campaign.yaml",
        extended=expand(
            RESULTS / "diagnosis" / "extended" / "{flight}.json",
            flight=PAYLOAD_FLIGHTS,
        ),
    log:
        log_path("diagnose"),
    benchmark:
        bench_path("diagnose")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=700,
    params:
        alpha=DIAGNOSIS["alpha"],
        max_causes=DIAGNOSIS["max_causes"],
        min_gain=DIAGNOSIS["min_gain"],
        atmosphere=DIAGNOSIS["atmosphere"],
        bootstrap=DIAGNOSIS["bootstrap"],
        flights=PAYLOAD_FLIGHTS,
        masts={f: reference_l1(f) for f in PAYLOAD_FLIGHTS},
        processing=CHAIN,
        fresh_seeds=fresh_seeds(DIAGNOSIS["seeds"]),
    script:
        "../scripts/diagnose.py"


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
    threads: 1
    resources:
        mem_mb=300,
    params:
        flight_id="{flight}",
        alpha=DIAGNOSIS["alpha"],
        segment_s=DIAGNOSIS["platform"]["segment_s"],
        band_factor=DIAGNOSIS["platform"]["band_factor"],
        flight=flight_entry,
        max_lag_s=PROCESSING["rigid_mount"]["max_lag_s"],
    script:
        "../scripts/diagnose_platform.py"


# A campaign without sling-load flights: diagnosis.json holds the rigid flights' results. The
# wildcard ("diagnosis") matches only in such a campaign; there this rule makes diagnosis.json.
rule diagnose_rigid:
    input:
        manifest=str(CAMPAIGN.path),
        platform=expand(
            RESULTS / "diagnosis" / "platform" / "{flight}.json",
            flight=RIGID_FLIGHTS,
        ),
    output:
        json=RESULTS / "{diagnosis}.json",
    log:
        log_path("diagnose_rigid", "diagnosis"),
    benchmark:
        bench_path("diagnose_rigid", "diagnosis")
    wildcard_constraints:
        diagnosis=only_if(RIGID_FLIGHTS and not PAYLOAD_FLIGHTS, ["diagnosis"]),
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    script:
        "../scripts/rigid_diagnosis.py"


ruleorder: diagnose_rigid > diagnose


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
    threads: 1
    resources:
        mem_mb=400,
    script:
        "../scripts/diagnosis_report.py"
