"""A small virtual campaign for workflow tests (8-min payload flights, one mast sonic)."""

from __future__ import annotations

from pathlib import Path

import yaml

#: Baseline seeds of the small campaign's workflow tests: they check the workflow's wiring, not
#: the diagnosis' statistics (which need the default, enough seeds for 640 pooled degrees of
#: freedom, and are tested in tests/diagnose/test_diagnose_calibration.py and the hidden-effect draws).
SMALL_SEEDS = (101, 202, 303, 404, 505)

#: Extra config for the small campaign: its 8-min hover is shorter than the paper's 10 min, and
#: its diagnosis runs with few seeds and bootstrap replicates (:data:`SMALL_SEEDS`).
SHORT_HOVER = f"""processing:
  hover:
    alt_tol_m: 3.0
    horiz_tol_m: 4.0
    min_duration_s: 300
diagnosis:
  seeds: {list(SMALL_SEEDS)}
  bootstrap: 100
"""

#: Flights of the small campaign, in order: id, hover window (UTC) and simulated conditions.
FLIGHTS = (
    ("s01", "2023-08-21T14:05:00Z", "2023-08-21T14:13:00Z",
     {"mean_speed_ms": 4.0, "wind_from_deg": 250.0, "z_over_L": -0.2, "hover_height_m": 28.0}),
    ("s02", "2023-08-21T15:05:00Z", "2023-08-21T15:13:00Z",
     {"mean_speed_ms": 6.0, "wind_from_deg": 220.0, "z_over_L": -0.1, "hover_height_m": 28.0}),
)


def _flight(flight_id: str, start: str, end: str) -> dict:
    return {
        "id": flight_id,
        "reference": "mast30",
        "target_height_m": 30,
        "sonic": {"file": f"flights/{flight_id}/sonic.csv", "mount": "upside_down"},
        "ins": {"file": f"flights/{flight_id}/ins.csv"},
        "window": {"start": start, "end": end},
    }


def write_small_campaign(folder: Path, name: str = "smallcamp", n_flights: int = 1) -> Path:
    """Write a small simulated campaign manifest into ``folder`` and return its path.

    Parameters
    ----------
    folder : Path
        Folder of the manifest.
    name : str
        Campaign name.
    n_flights : int
        Number of payload flights (1 or 2; one hour apart, each with an 8-min hover).

    Returns
    -------
    Path
        The manifest.
    """
    flights = FLIGHTS[:n_flights]
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
        "payload_flights": [_flight(fid, start, end) for fid, start, end, _ in flights],
        "simulation": {
            "seed": 7,
            "payload_flights": {fid: dict(conditions) for fid, _, _, conditions in flights},
        },
    }
    path = Path(folder) / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path
