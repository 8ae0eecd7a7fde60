# SWUF-3D quadrotor fleet (seed 001): per-flight L1 and windows, campaign calibration and
# tables, per-flight calibrated L2 wind, diagnosis of the single-law model, figures.
# Rules per flight are generated in a loop (each flight has its own set of UAVs).
from dronewind.steps.quadrotor import QUAD_TABLES

if CAMPAIGN.simulated:
    for _qf in QUAD_FLIGHTS:

        rule:
            name:
                f"quadrotor_simulate_{_qf}"
            input:
                manifest=str(CAMPAIGN.path),
            output:
                uavs=quad_raw(_qf)[0],
                reference=quad_raw(_qf)[1],
            log:
                str(RESULTS / "logs" / "quadrotor_simulate" / f"{_qf}.log"),
            benchmark:
                str(RESULTS / "benchmarks" / "quadrotor_simulate" / f"{_qf}.tsv")
            conda:
                ENV
            params:
                flight=_qf,
                out_dir=quad_l0_root,
            script:
                "../../scripts/quadrotor_simulate.py"


for _qf in QUAD_FLIGHTS:

    rule:
        name:
            f"quadrotor_flight_{_qf}"
        input:
            manifest=str(CAMPAIGN.path),
            uavs=quad_raw(_qf)[0],
            reference=quad_raw(_qf)[1],
        output:
            l1=quad_nc("L1", _qf),
            windows=quad_windows("windows", [_qf])[0],
            blocks=quad_windows("blocks", [_qf])[0],
            problems=quad_windows("problems", [_qf])[0],
        log:
            str(RESULTS / "logs" / "quadrotor_flight" / f"{_qf}.log"),
        benchmark:
            str(RESULTS / "benchmarks" / "quadrotor_flight" / f"{_qf}.tsv")
        conda:
            ENV
        params:
            flight=_qf,
            uavs=quad_uavs(_qf),
        script:
            "../../scripts/quadrotor_flight.py"

    rule:
        name:
            f"quadrotor_l2_{_qf}"
        input:
            manifest=str(CAMPAIGN.path),
            l1=quad_nc("L1", _qf),
            calibration=RESULTS / "tables" / "quadrotor_calibration.csv",
            summary=QUAD_DIR / "calibration.json",
        output:
            l2=quad_nc("L2", _qf),
        log:
            str(RESULTS / "logs" / "quadrotor_l2" / f"{_qf}.log"),
        benchmark:
            str(RESULTS / "benchmarks" / "quadrotor_l2" / f"{_qf}.tsv")
        conda:
            ENV
        params:
            flight=_qf,
            uavs=quad_uavs(_qf),
        script:
            "../../scripts/quadrotor_l2.py"


rule quadrotor_calibration:
    """Seed 001 Sect. 5: calibrations, Tables 2, 3, C1, C2 and the contract table."""
    input:
        manifest=str(CAMPAIGN.path),
        windows=quad_windows("windows"),
        blocks=quad_windows("blocks"),
        problems=quad_windows("problems"),
    output:
        tables=[str(RESULTS / "tables" / f"{t}.csv") for t in QUAD_TABLES],
        summary=QUAD_DIR / "calibration.json",
    log:
        log_path("quadrotor_calibration"),
    benchmark:
        bench_path("quadrotor_calibration")
    conda:
        ENV
    params:
        tables_dir=lambda wc, output: str(Path(output.tables[0]).parent),
    script:
        "../../scripts/quadrotor_calibration.py"


rule quadrotor_diagnosis:
    """The single-law quasi-steady model against the data: causes named, held-out gain."""
    input:
        manifest=str(CAMPAIGN.path),
        windows=quad_windows("windows"),
        blocks=quad_windows("blocks"),
        runs=[str(TUNNEL_RUNS)] if TUNNEL_RUNS is not None else [],
    output:
        RESULTS / "quadrotor_diagnosis.json",
    log:
        log_path("quadrotor_diagnosis"),
    benchmark:
        bench_path("quadrotor_diagnosis")
    conda:
        ENV
    script:
        "../../scripts/quadrotor_diagnosis.py"


rule quadrotor_figures:
    """Seed 001 Figs 3-9, drawn from the stored tables and L2 files."""
    input:
        tables=[str(RESULTS / "tables" / f"{t}.csv") for t in QUAD_TABLES],
        summary=QUAD_DIR / "calibration.json",
        l2=lambda wc: quad_nc("L2", quad_timeseries_flight()),
        reference=lambda wc: quad_raw(quad_timeseries_flight())[1],
    output:
        [str(RESULTS / "figures" / f"{name}.png") for name in QUAD_FIGURES],
    log:
        log_path("quadrotor_figures"),
    benchmark:
        bench_path("quadrotor_figures")
    conda:
        ENV
    params:
        tables_dir=lambda wc, input: str(Path(input.tables[0]).parent),
    script:
        "../../scripts/quadrotor_figures.py"
