# Tower- and mast-only campaigns (no payload or rigid-mount flight): each mast sonic's L1 in
# blocks of processing.block_s (30 min by default, aligned to UTC) to one L4 file per sonic with
# the blocks along time; tables/block_stats.csv from all sonics; the block-series figure.
# Flight campaigns do not build these by default (their mast records are the flights'
# references); the rules exist for them too, so `snakemake results/<name>/tables/block_stats.csv`
# builds the table on request.


rule mast_blocks:
    input:
        RESULTS / "netcdf" / "L1" / "mast_{sonic}.nc",
    output:
        RESULTS / "netcdf" / "L4" / "blocks" / "{sonic}.nc",
    log:
        log_path("mast_blocks", "sonic"),
    benchmark:
        bench_path("mast_blocks", "sonic")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=1000,
    params:
        campaign=CAMPAIGN.name,
        sonic=mast_sonic,
        processing=BLOCK_PROCESSING,
    script:
        "../scripts/mast_blocks.py"


rule block_stats:
    input:
        expand(RESULTS / "netcdf" / "L4" / "blocks" / "{sonic}.nc", sonic=MAST_SONICS),
    output:
        RESULTS / "tables" / "block_stats.csv",
    log:
        log_path("block_stats"),
    benchmark:
        bench_path("block_stats")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=400,
    script:
        "../scripts/block_stats.py"


rule block_figures:
    input:
        RESULTS / "tables" / "block_stats.csv",
    output:
        png=report(
            RESULTS / "figures" / f"{BLOCK_FIGURE}.png",
            caption=report_caption(BLOCK_FIGURE),
            category="Tower and mast records",
            subcategory="Block statistics",
        ),
        pdf=RESULTS / "figures" / f"{BLOCK_FIGURE}.pdf",
    log:
        log_path("block_figures"),
    benchmark:
        bench_path("block_figures")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=500,
    script:
        "../scripts/block_figures.py"
