# SWUF-3D quadrotor fleet (Wetz et al. 2021): L1 of a flight's UAVs, averaging windows per flight,
# campaign calibration and tables, calibrated L2 wind of a flight's UAVs, diagnosis of the
# single-law model, figures. Per-flight rules take what they read of the flight's manifest
# entry as params (never the manifest file), so a change to one flight reruns only that
# flight's jobs up to the windows (the L2 of every flight follows the campaign calibration).
from dronewind.quadrotor import QUAD_TABLES

# quadrotor figures in the report's "Validation" subcategory (the others: "Calibration")
QUAD_VALIDATION = (
    "quadrotor_fig5_validation",
    "quadrotor_fig7_timeseries",
    "quadrotor_fig8_profiles",
    "quadrotor_fig9_variance",
)

if CAMPAIGN.simulated:
    # One simulate rule per flight: its outputs are the files the manifest names for the
    # flight's UAVs and tower, which no wildcard pattern can describe.
    for _qf in QUAD_FLIGHTS:

        rule:
            name:
                f"quadrotor_simulate_{_qf}"
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
                flight=canonical(CAMPAIGN.quadrotor_flight(_qf)),
                simulation=quad_simulation(_qf),
                site=SITE,
                out_dir=quad_l0_root,
            script:
                "../../scripts/quadrotor_simulate.py"


# L1 and L2 run one job per flight, for all its UAVs (one process pays the library imports
# once per flight): one rule per flight, whose outputs are the per-UAV files of the flight's
# UAVs, which no wildcard pattern can describe.
for _qf in QUAD_FLIGHTS:

    rule:
        name:
            f"quadrotor_l1_{_qf}"
        input:
            raw=quad_raw(_qf)[0],
        output:
            quad_nc("L1", _qf),
        log:
            str(RESULTS / "logs" / "quadrotor_l1" / f"{_qf}.log"),
        benchmark:
            str(RESULTS / "benchmarks" / "quadrotor_l1" / f"{_qf}.tsv")
        conda:
            ENV
        params:
            campaign=CAMPAIGN.name,
            flight_id=_qf,
            uavs=quad_uavs(_qf),
            formats=[u.get("format") for u in CAMPAIGN.quadrotor_flight(_qf)["uavs"]],
            site=SITE,
            simulated=CAMPAIGN.simulated,
            attribution=ATTRIBUTION,
        script:
            "../../scripts/quadrotor_l1.py"


rule quadrotor_windows:
    """Wetz et al. (2021) Sect. 5 and App. C: 10-min and 2-min windows of a flight's UAVs with the tower."""
    input:
        l1=lambda wc: quad_nc("L1", wc.qflight),
        reference=lambda wc: quad_raw(wc.qflight)[1],
    output:
        windows=QUAD_DIR / "windows" / "{qflight}_windows.csv",
        blocks=QUAD_DIR / "windows" / "{qflight}_blocks.csv",
        problems=QUAD_DIR / "windows" / "{qflight}_problems.csv",
    log:
        log_path("quadrotor_windows", "qflight"),
    benchmark:
        bench_path("quadrotor_windows", "qflight")
    conda:
        ENV
    params:
        flight=quad_flight,
        site_altitude_m=SITE["altitude_m"],
        block_s=QUAD["block_s"],
        hover=QUAD["hover"],
    script:
        "../../scripts/quadrotor_windows.py"


rule quadrotor_calibration:
    """Wetz et al. (2021) Sect. 5: calibrations, Tables 2, 3, C1, C2 and the contract table."""
    input:
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
    priority: PRIORITY_CHAIN
    conda:
        ENV
    params:
        campaign=CAMPAIGN.name,
        tables_dir=lambda wc, output: str(Path(output.tables[0]).parent),
        calibration_window_s=QUAD["calibration_window_s"],
        roles={f["id"]: f.get("role", "") for f in CAMPAIGN.quadrotor_flights},
    script:
        "../../scripts/quadrotor_calibration.py"


for _qf in QUAD_FLIGHTS:

    rule:
        name:
            f"quadrotor_l2_{_qf}"
        input:
            l1=quad_nc("L1", _qf),
            calibration=RESULTS / "tables" / "quadrotor_calibration.csv",
            summary=QUAD_DIR / "calibration.json",
        output:
            quad_nc("L2", _qf),
        log:
            str(RESULTS / "logs" / "quadrotor_l2" / f"{_qf}.log"),
        benchmark:
            str(RESULTS / "benchmarks" / "quadrotor_l2" / f"{_qf}.tsv")
        conda:
            ENV
        params:
            campaign=CAMPAIGN.name,
            flight_id=_qf,
            uavs=quad_uavs(_qf),
            site=SITE,
            average_s=QUAD["average_s"],
            hover=QUAD["hover"],
        script:
            "../../scripts/quadrotor_l2.py"


rule quadrotor_diagnosis:
    """The single-law quasi-steady model against the data: causes named, held-out gain."""
    input:
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
    params:
        campaign=CAMPAIGN.name,
        alpha=DIAGNOSIS["alpha"],
        min_gain=QUAD["diagnosis"]["min_gain"],
        window_s=QUAD["diagnosis"]["window_s"],
    script:
        "../../scripts/quadrotor_diagnosis.py"


rule quadrotor_figures:
    """Wetz et al. (2021) Figs 3-9, drawn from the stored tables and L2 files."""
    input:
        tables=[str(RESULTS / "tables" / f"{t}.csv") for t in QUAD_TABLES],
        summary=QUAD_DIR / "calibration.json",
        l2=lambda wc: quad_nc("L2", quad_timeseries_flight()),
        reference=lambda wc: quad_raw(quad_timeseries_flight())[1],
    output:
        [
            report(
                str(RESULTS / "figures" / f"{name}.png"),
                caption=report_caption(name),
                category="Quadrotor fleet",
                subcategory="Validation" if name in QUAD_VALIDATION else "Calibration",
            )
            for name in QUAD_FIGURES
        ],
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
