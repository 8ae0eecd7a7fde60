"""A small virtual campaign for workflow tests (one short payload flight, two mast sonics)."""

from __future__ import annotations

from pathlib import Path

import yaml


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
            }
        ],
        "simulation": {"seed": 7},
    }
    path = Path(folder) / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path
