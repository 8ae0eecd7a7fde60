# SWUF-3D quadrotor fleet (Wetz et al. 2021): L1 of every UAV and averaging windows of every
# flight, campaign calibration and tables, calibrated L2 wind of every UAV, diagnosis of the
# single-law model, figures. The fleet rules take what they read of the flights' manifest
# entries as params (never the manifest file).
from dronewind.quadrotor import QUAD_TABLES

# quadrotor figures in the report's "Validation" subcategory (the others: "Calibration")
QUAD_VALIDATION = (
    "quadrotor_fig5_validation",
    "quadrotor_fig7_timeseries",
    "quadrotor_fig8_profiles",
    "quadrotor_fig9_variance",
)


# The cheap per-flight stages of the whole fleet run in three jobs: the simulation of every
# flight's logs (virtual campaigns), L1 and averaging windows of every flight in one, the L2 of
# every flight in one after the campaign calibration. A flight's UAV files are named in the
# manifest (its UAV ids), which no wildcard pattern describes; the jobs list them all
# (docs/workflow.md).


# a virtual campaign writes every quadrotor flight's UAV logs and tower reference (no output otherwise)
rule quadrotor_simulate:
    """The SWUF-3D fleet's logs and the tower reference of every quadrotor flight of a virtual campaign."""
    output:
        l0=quad_raw_all() if CAMPAIGN.simulated else [],
    log:
        log_path("quadrotor_simulate"),
    benchmark:
        bench_path("quadrotor_simulate")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=600,
    params:
        flights=[
            {
                "flight": canonical(CAMPAIGN.quadrotor_flight(f)),
                "simulation": quad_simulation(f),
            }
            for f in (QUAD_FLIGHTS if CAMPAIGN.simulated else [])
        ],
        site=SITE,
        l0_dir=quad_l0_root,
    script:
        "../scripts/quadrotor_simulate.py"


rule quadrotor_fleet:
    """Wetz et al. (2021) Sect. 5 and App. C: L1 of every UAV, 10-min and 2-min windows of every flight with the tower."""
    input:
        raw=quad_raw_all(),
    output:
        l1=quad_nc_all("L1"),
        windows=quad_windows("windows"),
        blocks=quad_windows("blocks"),
        problems=quad_windows("problems"),
    log:
        log_path("quadrotor_fleet"),
    benchmark:
        bench_path("quadrotor_fleet")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        flights=quad_fleet(QUAD_FLIGHTS),
        site=SITE,
        simulated=CAMPAIGN.simulated,
        attribution=ATTRIBUTION,
        site_altitude_m=SITE["altitude_m"],
        block_s=QUAD["block_s"],
        hover=QUAD["hover"],
    script:
        "../scripts/quadrotor_fleet.py"


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
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        tables_dir=lambda wc, output: str(Path(output.tables[0]).parent),
        calibration_window_s=QUAD["calibration_window_s"],
        roles={f["id"]: f.get("role", "") for f in CAMPAIGN.quadrotor_flights},
    script:
        "../scripts/quadrotor_calibration.py"


rule quadrotor_l2:
    """Wetz et al. (2021): calibrated 1 Hz wind (L2) of every UAV of every flight."""
    input:
        l1=quad_nc_all("L1"),
        calibration=RESULTS / "tables" / "quadrotor_calibration.csv",
        summary=QUAD_DIR / "calibration.json",
    output:
        quad_nc_all("L2"),
    log:
        log_path("quadrotor_l2"),
    benchmark:
        bench_path("quadrotor_l2")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        flights={f: quad_uavs(f) for f in QUAD_FLIGHTS},
        site=SITE,
        average_s=QUAD["average_s"],
        hover=QUAD["hover"],
    script:
        "../scripts/quadrotor_l2.py"


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
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        alpha=DIAGNOSIS["alpha"],
        min_gain=QUAD["diagnosis"]["min_gain"],
        window_s=QUAD["diagnosis"]["window_s"],
    script:
        "../scripts/quadrotor_diagnosis.py"


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
        [str(RESULTS / "figures" / f"{name}.pdf") for name in QUAD_FIGURES],
    log:
        log_path("quadrotor_figures"),
    benchmark:
        bench_path("quadrotor_figures")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        tables_dir=lambda wc, input: str(Path(input.tables[0]).parent),
    script:
        "../scripts/quadrotor_figures.py"
