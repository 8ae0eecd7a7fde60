"""Diagnose finished hidden-effect workflow runs again from their files (any code version).

Each argument is a draw folder of ``tests/test_diagnosis_hidden.py`` (``hidden.yaml`` and
``results/hidden/diagnosis/{measured,forward}``); prints the named causes, their estimates and
the three best candidates. With ``PYTHONPATH`` set to an older source tree it uses that
version's diagnosis, so one run's campaigns are compared across versions::

    PYTHONPATH=/tmp/base/src .venv/bin/python benchmarks/rediagnose.py \\
        /tmp/pytest-of-root/pytest-current/hidden0/draw1
"""

import argparse
import json
import tempfile
from pathlib import Path

from dronewind.manifest import default_config
from dronewind.steps.diagnosis import diagnose_campaign


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("draws", nargs="+", type=Path, help="draw folders of a hidden-effect test run")
    args = parser.parse_args()
    d = default_config()["diagnosis"]
    for draw in args.draws:
        r = draw / "results" / "hidden" / "diagnosis"
        with tempfile.TemporaryDirectory() as tmp:
            diagnose_campaign(draw / "hidden.yaml", sorted((r / "measured").glob("*.json")),
                              sorted((r / "forward").glob("*.json")), Path(tmp) / "d.json", Path(tmp) / "e.yaml",
                              alpha=d["alpha"], max_causes=d["max_causes"], min_gain=d["min_gain"],
                              atmosphere=d["atmosphere"])
            out = json.loads((Path(tmp) / "d.json").read_text())
        print(draw.name, out["named_causes"], {k: v["estimate"] for k, v in out["named_estimates"].items()},
              [(c["mechanism"], round(c["gain"], 3), f'{c["p_value"]:.2g}') for c in out["candidates"][:3]])


if __name__ == "__main__":
    main()
