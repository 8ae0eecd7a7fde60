"""A small virtual campaign for workflow tests (one 8-min payload flight, one mast sonic)."""

from __future__ import annotations

from pathlib import Path

import yaml


#: Extra config for the small campaign: its 8-min hover is shorter than the paper's 10 min.
SHORT_HOVER = """processing:
  hover:
    alt_tol_m: 3.0
    horiz_tol_m: 4.0
    min_duration_s: 300
"""


def write_small_campaign(folder: Path, name: str = "smallcamp") -> Path:
    """Write a small simulated campaign manifest into ``folder`` and return its path."""
    data = {
        "name": name,
        "site": {"name": "P2OA Lannemezan", "latitude": 43.1247, "longitude": 0.3628, "altitude_m": 603},
        "masts": [
            {
                "id": "p2oa",
                "latitude": 43.1247,
                "longitude": 0.3628,
                "sonics": [
                    {"id": "mast30", "height_m": 30, "model": "CSAT3", "azimuth_deg": 218.0,
                     "files": ["mast/mast30_*.dat"]},
                ],
            }
        ],
        "payload_flights": [
            {
                "id": "s01",
                "reference": "mast30",
                "target_height_m": 30,
                "sonic": {"file": "flights/s01/sonic.csv", "mount": "upside_down"},
                "ins": {"file": "flights/s01/ins.csv"},
                "window": {"start": "2023-08-21T14:05:00Z", "end": "2023-08-21T14:13:00Z"},
            }
        ],
        "simulation": {
            "seed": 7,
            "payload_flights": {
                "s01": {"mean_speed_ms": 4.0, "wind_from_deg": 250.0, "z_over_L": -0.2, "hover_height_m": 28.0},
            },
        },
    }
    path = Path(folder) / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path
