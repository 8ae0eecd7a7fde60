# Campaign-level records, tables, figures and the HTML report.
#
# The report (`snakemake --report results/<name>/report.html`) opens on the campaign's front
# page (rule report_pages: verdict, tables, figure index), written from the stored results and
# included by workflow/report/workflow.rst. Every figure's caption is a file that rule writes
# from the data it shows (report_caption() in common.smk); every report item has a category
# and a subcategory, so no "Other" section appears.

from dronewind.figures.labels import REPORT_TABLES

#: Subcategory of each campaign figure in the report (category "Payload validation").
FIGURE_SUBCATEGORIES = {
    "fig04_tke_lag": "Synchronisation and positions",
    "fig07_positions": "Synchronisation and positions",
    "fig08_timeseries": "Time series",
    "fig10_temperature_series": "Time series",
    "fig09_velocity_spectra": "Spectra",
    "fig11_temperature_spectra": "Spectra",
    "figB1_normalised_velocity_spectra": "Spectra",
    "figB2_normalised_temperature_spectra": "Spectra",
    "fig12_mean_and_sigma": "Statistics and fluxes",
    "fig13_fluxes_obukhov": "Statistics and fluxes",
    "fig14_length_scales": "Statistics and fluxes",
    "fig16_uncertainty": "Statistics and fluxes",
    "fig15_quadrant": "Spectral ratios",
}
#: Subcategory of each table page in the report (category "Tables").
TABLE_SUBCATEGORIES = {
    "table4_flights": "Payload flights",
    "table5_statistics": "Payload flights",
    "flight_stats": "Payload flights",
    "validation": "Payload flights",
    "diagnosis_evidence": "Diagnosis",
    "published_numbers": "Diagnosis",
    "quadrotor_calibration": "Quadrotor fleet",
    "quadrotor_table2": "Quadrotor fleet",
    "quadrotor_table3": "Quadrotor fleet",
    "tunnel_calibration": "Wind tunnel",
    "block_stats": "Tower and mast records",
}


# What this campaign's report shows: figures (name -> PNG), table pages, and the stored results
# the front page and the captions are written from.
REPORT_FIGURES = {
    name: str(RESULTS / "figures" / f"{name}.png")
    for name in (
        FIGURES + ["diagnosis_residuals", "diagnosis_spectra"]
        if PAYLOAD_FLIGHTS
        else []
    )
    + (["published_before_after"] if PUBLISHED else [])
    + (list(QUAD_FIGURES) if QUAD_FLIGHTS else [])
    + (list(TUNNEL_FIGURES) if TUNNEL_RUNS is not None else [])
    + ([BLOCK_FIGURE] if BLOCK_SONICS else [])
}
REPORT_TABLE_NAMES = (
    (
        [
            "validation",
            "table4_flights",
            "table5_statistics",
            "flight_stats",
            "diagnosis_evidence",
        ]
        if PAYLOAD_FLIGHTS
        else []
    )
    + (["flight_stats"] if RIGID_FLIGHTS and not PAYLOAD_FLIGHTS else [])
    + (["published_numbers"] if PUBLISHED else [])
    + (
        ["quadrotor_calibration", "quadrotor_table2", "quadrotor_table3"]
        if QUAD_FLIGHTS
        else []
    )
    + (["tunnel_calibration"] if TUNNEL_RUNS is not None else [])
    + (["block_stats"] if BLOCK_SONICS else [])
)
REPORT_INPUTS = list(
    dict.fromkeys(
        [str(RESULTS / "campaign.json")]
        + [str(RESULTS / REPORT_TABLES[t][1]) for t in REPORT_TABLE_NAMES]
        + (
            [str(RESULTS / "diagnosis.json")]
            + expand(
                str(RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc"),
                flight=PAYLOAD_FLIGHTS,
                sensor=["drone", "mast"],
            )
            if PAYLOAD_FLIGHTS
            else []
        )
        + ([str(RESULTS / "diagnosis.json")] if RIGID_FLIGHTS else [])
        + (
            [
                str(RESULTS / "published" / "diagnosis.json"),
                str(RESULTS / "published" / "before_after.json"),
            ]
            if PUBLISHED
            else []
        )
        + (
            [str(RESULTS / "quadrotor_diagnosis.json")]
            if QUAD_FLIGHTS or TUNNEL_RUNS is not None
            else []
        )
        + autopilot_targets()
    )
)


rule campaign_record:
    """Record the validated manifest (normalised) with its checksum and the config hash."""
    input:
        manifest=str(CAMPAIGN.path),
    output:
        RESULTS / "campaign.json",
    log:
        log_path("campaign_record"),
    benchmark:
        bench_path("campaign_record")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=200,
    params:
        config=canonical(dict(config)),
    script:
        "../scripts/campaign_record.py"


rule tables:
    input:
        expand(
            RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc",
            flight=PAYLOAD_FLIGHTS,
            sensor=["drone", "mast"],
        ),
    output:
        multiext(str(RESULTS / "tables" / "table4_flights"), ".csv", ".md", ".tex"),
        multiext(str(RESULTS / "tables" / "table5_statistics"), ".csv", ".md", ".tex"),
        multiext(str(RESULTS / "tables" / "validation"), ".csv", ".md"),
    log:
        log_path("tables"),
    benchmark:
        bench_path("tables")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    script:
        "../scripts/tables.py"


# The campaign figures in two jobs of about equal length (the normalised spectra of Appendix B
# take as long as the others together): each stays within the first 15 s of a job, which
# Snakemake's benchmark samples every 0.5 s (then every 30 s), so its benchmark file holds the
# job's whole CPU time (figure_outputs() in common.smk).
rule figures:
    """Ghirardelli et al. (2025) Figs 4 and 7-16 from the stored products."""
    input:
        l2=expand(
            RESULTS / "netcdf" / "L2" / "{flight}_drone.nc", flight=PAYLOAD_FLIGHTS
        ),
        l3=expand(RESULTS / "netcdf" / "L3" / "{flight}.nc", flight=PAYLOAD_FLIGHTS),
        l4=expand(
            RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc",
            flight=PAYLOAD_FLIGHTS,
            sensor=["drone", "mast"],
        ),
        campaign=RESULTS / "campaign.json",
    output:
        **figure_outputs(MAIN_FIGURES),
    log:
        log_path("figures"),
    benchmark:
        bench_path("figures")
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=600,
    params:
        results=results_of_l4,
        names=MAIN_FIGURES,
    script:
        "../scripts/figures.py"


rule figures_appendix:
    """Ghirardelli et al. (2025) Figs B1 and B2 (normalised spectra) from the stored L4 products."""
    input:
        l4=expand(
            RESULTS / "netcdf" / "L4" / "{flight}_{sensor}.nc",
            flight=PAYLOAD_FLIGHTS,
            sensor=["drone", "mast"],
        ),
    output:
        **figure_outputs(APPENDIX_FIGURES),
    log:
        log_path("figures_appendix"),
    benchmark:
        bench_path("figures_appendix")
    priority: PRIORITY_FORWARD
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=400,
    params:
        results=results_of_l4,
        names=list(APPENDIX_FIGURES),
    script:
        "../scripts/figures.py"


rule report_pages:
    """The report's front page, table pages and figure captions, from the stored results."""
    input:
        results=REPORT_INPUTS,
        figures=list(REPORT_FIGURES.values()),
    output:
        summary=report(
            RESULTS / "report" / "summary.html",
            caption="../report/summary.rst",
            category="Campaign",
            subcategory="Front page",
        ),
        captions=[
            str(RESULTS / "report" / "captions" / f"{name}.rst")
            for name in REPORT_FIGURES
        ],
        tables=[
            report(
                str(RESULTS / "report" / "tables" / f"{name}.html"),
                caption="../report/table.rst",
                category="Tables",
                subcategory=TABLE_SUBCATEGORIES[name],
            )
            for name in REPORT_TABLE_NAMES
        ],
    log:
        log_path("report_pages"),
    benchmark:
        bench_path("report_pages")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        results=lambda wc, input: str(Path(input.results[0]).parent),
        out_dir=lambda wc, output: str(Path(output.summary).parent),
        figures=REPORT_FIGURES,
        tables=REPORT_TABLE_NAMES,
    script:
        "../scripts/report_pages.py"
