# Autopilot flights (manifest `autopilot_flights`): a multicopter's tilt-based wind against the
# wind its autopilot's EKF estimates. One job per flight writes its L3 and L4; one campaign job
# writes the table of every flight and a figure per flight. The per-flight rule takes the
# flight's manifest entry as params (a change to one flight reruns only its jobs). Helpers
# (AUTOPILOT_FLIGHTS, autopilot_entry, autopilot_targets) are in common.smk.
rule autopilot_wind:
    """Tilt wind (Wetz et al. 2021, Eqs. 12-18) and EKF wind of one flight: L3 and L4."""
    input:
        raw=lambda wc: str(L0 / CAMPAIGN.autopilot_flight(wc.aflight)["file"]),
    output:
        l3=AUTOPILOT_DIR / "L3" / "autopilot" / "{aflight}.nc",
        l4=AUTOPILOT_DIR / "L4" / "autopilot" / "{aflight}.nc",
    log:
        log_path("autopilot_wind", "aflight"),
    benchmark:
        bench_path("autopilot_wind", "aflight")
    wildcard_constraints:
        aflight=_alternatives(AUTOPILOT_FLIGHTS),
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=500,
    params:
        campaign=CAMPAIGN.name,
        flight=autopilot_entry,
        site=SITE,
        simulated=CAMPAIGN.simulated,
    script:
        "../scripts/autopilot_wind.py"


rule autopilot_summary:
    """The comparison table of every autopilot flight and a figure per flight."""
    input:
        l3=expand(
            AUTOPILOT_DIR / "L3" / "autopilot" / "{aflight}.nc",
            aflight=AUTOPILOT_FLIGHTS,
        ),
        l4=expand(
            AUTOPILOT_DIR / "L4" / "autopilot" / "{aflight}.nc",
            aflight=AUTOPILOT_FLIGHTS,
        ),
    output:
        table=RESULTS / "tables" / "autopilot_ekf_wind.csv",
        figures=[
            report(
                str(RESULTS / "figures" / f"autopilot_ekf_wind_{f}.png"),
                caption="../report/autopilot_ekf_wind.rst",
                category="Autopilot wind",
            )
            for f in AUTOPILOT_FLIGHTS
        ],
    log:
        log_path("autopilot_summary"),
    benchmark:
        bench_path("autopilot_summary")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=400,
    script:
        "../scripts/autopilot_summary.py"
