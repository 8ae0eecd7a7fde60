"""The published-results file (``config/published/*.yaml``): reading and checking it.

Apart from the diagnosis of the published numbers (:mod:`dronewind.diagnose.published`), so
that reading the file imports no array or statistics library: the Snakefile reads it each
time Snakemake starts, to know the samples of the published-numbers rules.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from dronewind.core.yamltext import load_yaml
from dronewind.errors import InputError

__all__ = ["TABLE5_FEATURES", "load_published"]

#: Feature -> Table 5 statistic it is computed from.
TABLE5_FEATURES: dict[str, str] = {
    "ln_sigma_ratio_u": "sigma_u_ms",
    "ln_sigma_ratio_v": "sigma_v_ms",
    "ln_sigma_ratio_w": "sigma_w_ms",
    "ln_speed_ratio": "U_ms",
}


def _require(node: Mapping[str, Any], key: str, where: str, path: Path) -> Any:
    if not isinstance(node, Mapping) or key not in node:
        raise InputError(f"{path}: {where}.{key}" if where else f"{path}: {key}", "missing key")
    return node[key]


def load_published(path: str | Path) -> dict[str, Any]:
    """Read and check a published-results file (``config/published/*.yaml``).

    Parameters
    ----------
    path : str or Path
        YAML file with ``source``, ``stationary_flights``, ``table4``, ``table5``, ``claims``.

    Returns
    -------
    dict
        The file's content.

    Raises
    ------
    InputError
        Naming the file and the key path of the first missing or malformed entry.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(str(path), "published-results file does not exist")
    data = load_yaml(path.read_text())
    for key in ("source", "stationary_flights", "table4", "table5", "claims"):
        _require(data, key, "", path)
    _require(data["source"], "citation", "source", path)
    table4 = data["table4"]
    for flight in data["stationary_flights"]:
        row = _require(table4, flight, "table4", path)
        for key in ("start", "duration_min", "wind_from_deg", "payload_height_m", "wind_speed_ms", "zeta"):
            value = _require(row, key, f"table4.{flight}", path)
            if key != "start" and not isinstance(value, int | float):
                raise InputError(f"{path}: table4.{flight}.{key}", f"expected a number, got {value!r}")
        if row["wind_speed_ms"] < 0 or row["duration_min"] <= 0:
            raise InputError(f"{path}: table4.{flight}", "expected wind_speed_ms >= 0 and duration_min > 0")
    resolution = _require(data["table5"], "resolution", "table5", path)
    if not isinstance(resolution, int | float) or resolution < 0:
        raise InputError(f"{path}: table5.resolution", f"expected a number >= 0, got {resolution!r}")
    for flight, row in data["table5"].items():
        if flight == "resolution":
            continue
        if flight not in data["stationary_flights"]:
            raise InputError(f"{path}: table5.{flight}", "Table 5 flight is not among stationary_flights")
        for sensor in ("drone", "mast"):
            stats = _require(row, sensor, f"table5.{flight}", path)
            for stat in TABLE5_FEATURES.values():
                value = _require(stats, stat, f"table5.{flight}.{sensor}", path)
                if not isinstance(value, int | float) or value <= 0:
                    raise InputError(f"{path}: table5.{flight}.{sensor}.{stat}", f"expected a positive number, "
                                                                                 f"got {value!r}")
    for claim in ("sw_su_drone_max", "sw_su_mast_min"):
        entry = _require(data["claims"], claim, "claims", path)
        _require(entry, "value", f"claims.{claim}", path)
        _require(entry, "resolution", f"claims.{claim}", path)
    return data
