"""Snakemake script: Table 4 and Table 5 equivalents (CSV, Markdown, LaTeX) from the L4 files.

With a seventh output (``tables/validation.csv``, then ``.md``) it also writes the validation
answer, drone against mast per statistic (:func:`dronewind.steps.report.write_validation_table`).
"""

from pathlib import Path

from dronewind.steps import logged
from dronewind.tables import table_flight_statistics, table_flights

sm = snakemake  # noqa: F821 (snakemake is injected)
with logged(sm.log[0]):
    table_flights(list(sm.input), Path(sm.output[0]).with_suffix(""))
    table_flight_statistics(list(sm.input), Path(sm.output[3]).with_suffix(""))
    if len(sm.output) > 6:
        from dronewind.steps.report import write_validation_table

        write_validation_table(list(sm.input), Path(sm.output[6]).with_suffix(""))
