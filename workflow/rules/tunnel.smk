# Wind-tunnel calibration and verification of the quadrotors (Kistner et al. 2024): simulate (virtual
# campaigns with `simulation.tunnel`), analyse into tables, figures.
from dronewind.tunnel import TUNNEL_TABLES


# a virtual campaign with `simulation.tunnel` writes its tunnel programme (no output otherwise)
rule tunnel_simulate:
    output:
        [str(TUNNEL_RUNS)] if TUNNEL_SIMULATED and TUNNEL_RUNS is not None else [],
    log:
        log_path("tunnel_simulate"),
    benchmark:
        bench_path("tunnel_simulate")
    priority: PRIORITY_CHAIN
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=200,
    params:
        simulation=canonical(
            {
                k: v
                for k, v in (CAMPAIGN.data.get("simulation") or {}).items()
                if k in ("seed", "tunnel")
            }
        ),
        runs=TUNNEL_RUNS_REL,
        out_dir=lambda wc, output: str(
            Path(output[0]).parents[len(Path(TUNNEL_RUNS_REL).parts) - 1]
        ),
    script:
        "../scripts/tunnel_simulate.py"


rule tunnel_analysis:
    """Kistner et al. (2024): calibration per speed range, sideslip, portability, gusts, steps, turbulence."""
    input:
        runs=[str(TUNNEL_RUNS)] if TUNNEL_RUNS is not None else [],
    output:
        [str(RESULTS / "tables" / f"tunnel_{t}.csv") for t in TUNNEL_TABLES],
    log:
        log_path("tunnel_analysis"),
    benchmark:
        bench_path("tunnel_analysis")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=300,
    params:
        campaign=CAMPAIGN.name,
        tables_dir=lambda wc, output: str(Path(output[0]).parent),
    script:
        "../scripts/tunnel_analysis.py"


rule tunnel_figures:
    """Kistner et al. (2024) Figs 4-7 and 9, drawn from the stored tunnel tables."""
    input:
        [str(RESULTS / "tables" / f"tunnel_{t}.csv") for t in TUNNEL_TABLES],
    output:
        [
            report(
                str(RESULTS / "figures" / f"{name}.png"),
                caption=report_caption(name),
                category="Wind tunnel",
                subcategory="Calibration and verification",
            )
            for name in TUNNEL_FIGURES
        ],
        [str(RESULTS / "figures" / f"{name}.pdf") for name in TUNNEL_FIGURES],
    log:
        log_path("tunnel_figures"),
    benchmark:
        bench_path("tunnel_figures")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=200,
    params:
        tables_dir=lambda wc, input: str(Path(input[0]).parent),
    script:
        "../scripts/tunnel_figures.py"
