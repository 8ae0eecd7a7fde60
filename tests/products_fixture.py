"""A small synthetic products tree (L2, L3, L4, flight_stats.csv, campaign.json) for table and figure tests.

The layout is exactly that of ``results/<campaign>/`` written by :mod:`dronewind.steps`:

* ``netcdf/L2/<flight>_drone.nc``: GNSS track, wind and attitude series, the TKE-vs-lag
  curve (``lag_s``/``tke_m2s2`` on ``lag``), attrs ``lag_sonic_ins_s``, ``usable``,
  ``unusable_reason``, ``height_m``;
* ``netcdf/L2/<flight>_mast.nc``: the reference mast sonic over the flight window;
* ``netcdf/L3/<flight>.nc``: drone and mast in streamline coordinates at 8 Hz, group
  ``alignment``;
* ``netcdf/L4/<flight>_<sensor>.nc``: written by :func:`dronewind.steps.l4` itself from
  the L3 files (so the L4 layout cannot drift from the pipeline's);
* ``tables/flight_stats.csv`` by :func:`dronewind.steps.flight_stats`;
* ``campaign.json`` by :func:`dronewind.steps.campaign_record`.

Four flights, references at 30 m and 60 m: ``s01`` convective and light wind (30 m), ``s02``
calm (0.8 m/s: spectral ratios and length scales NaN by status), ``s03`` strong wind and
stable (60 m, drone w overestimated), ``s04`` at 60 m with the drone flagged unusable.
The L2/L3 content is synthetic (seeded) and only needs the right layout; the numbers in
L4 are whatever :func:`dronewind.compare.l4.flight_l4` computes from the L3 series.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import netCDF4
import numpy as np
import pandas as pd
import xarray as xr
import yaml

from dronewind import steps as pipeline
from dronewind.core.cf import split_standard, write_netcdf
from dronewind.manifest import default_config, load_campaign

SITE = {"name": "P2OA Lannemezan", "latitude": 43.1247, "longitude": 0.3628, "altitude_m": 603.0}
FS_L3_HZ = 8.0
FS_L2_HZ = 32.0
FS_MAST_HZ = 10.0


@dataclass(frozen=True)
class FlightSpec:
    """Conditions of one synthetic flight."""

    flight: str
    reference: str
    mast_height_m: float
    drone_height_m: float
    speed_ms: float
    wind_from_deg: float
    heat_sign: float  # +1 upward buoyancy flux (unstable), -1 downward (stable)
    drone_w_gain: float
    start: str
    minutes: float
    lag_sonic_ins_s: float
    lag_drone_mast_s: float
    offset_east_m: float
    offset_north_m: float
    usable: bool = True
    unusable_reason: str = ""


FLIGHTS: tuple[FlightSpec, ...] = (
    FlightSpec("s01", "mast30", 30.0, 27.5, 3.1, 97.0, +1.0, 1.1, "2023-08-21T14:05:32", 12.0,
               -0.094, 1.25, 35.0, 10.0),
    FlightSpec("s02", "mast30", 30.0, 27.0, 0.8, 277.0, -1.0, 1.0, "2023-12-07T12:33:52", 11.0,
               -0.031, 0.5, -25.0, 20.0),
    FlightSpec("s03", "mast60", 60.0, 51.0, 10.4, 304.0, -1.0, 1.3, "2023-12-13T07:53:37", 12.0,
               -0.156, -2.0, -40.0, 25.0),
    FlightSpec("s04", "mast60", 60.0, 52.0, 7.1, 296.0, -1.0, 1.2, "2023-12-13T10:19:58", 10.5,
               -0.125, -1.5, -30.0, 15.0, usable=False,
               unusable_reason="hover window 630 s shorter than ... (synthetic); sonic-INS lag at search edge"),
)


def _synthesise(psd, n: int, fs_hz: float, rng: np.random.Generator) -> np.ndarray:
    """Gaussian series with the shape of the one-sided PSD ``psd``, unit variance."""
    f = np.fft.rfftfreq(n, 1.0 / fs_hz)
    s = np.zeros_like(f)
    s[1:] = psd(f[1:])
    x = np.sqrt(s * fs_hz * n / 4.0) * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size))
    x[0] = x[-1] = 0.0
    y = np.fft.irfft(x, n=n)
    return y / np.std(y)


def _von_karman(length_m: float, speed_ms: float):
    def s_u(f):
        x2 = (2 * np.pi * f * length_m / speed_ms) ** 2
        return (1 + x2) ** (-5 / 6)

    def s_w(f):
        x2 = (2 * np.pi * f * length_m / speed_ms) ** 2
        return 0.5 * (1 + 8 / 3 * x2) / (1 + x2) ** (11 / 6)

    return s_u, s_w


def _l3_dataset(spec: FlightSpec, campaign: str, rng: np.random.Generator) -> xr.Dataset:
    n = int(spec.minutes * 60 * FS_L3_HZ)
    speed = max(spec.speed_ms, 1.0)
    s_u, s_w = _von_karman(2 * spec.mast_height_m, speed)
    data = {k: np.empty((2, n)) for k in ("u_ms", "v_ms", "w_ms", "theta_v_k")}
    common_u = _synthesise(s_u, n, FS_L3_HZ, rng)
    common_w = _synthesise(s_w, n, FS_L3_HZ, rng)
    scale = 0.22 * speed if spec.speed_ms >= 2 else 0.6
    for i, gain in enumerate((spec.drone_w_gain, 1.0)):
        u = common_u + 0.3 * _synthesise(s_u, n, FS_L3_HZ, rng)
        v = _synthesise(s_w, n, FS_L3_HZ, rng)
        w = common_w + 0.3 * _synthesise(s_w, n, FS_L3_HZ, rng)
        t = 0.15 * _synthesise(s_u, n, FS_L3_HZ, rng) + spec.heat_sign * (0.1 if spec.heat_sign > 0 else 0.03) * w
        data["u_ms"][i] = spec.speed_ms * (0.95 if i == 0 else 1.0) + scale * u
        data["v_ms"][i] = scale * v
        data["w_ms"][i] = scale * 0.8 * gain * (w - 0.3 * u)
        data["theta_v_k"][i] = (290.0 if i == 0 else 290.4) + t
    time = pd.date_range(spec.start, periods=n, freq="125ms").values.astype("datetime64[ns]")
    lag_grid = np.round(np.arange(-48, 49) / FS_L3_HZ, 6)
    xcorr = 0.8 * np.exp(-(((lag_grid - spec.lag_drone_mast_s) / 1.5) ** 2))
    ds = xr.Dataset(
        {
            "u_ms": (("sensor", "time"), data["u_ms"], {"units": "m s-1", "long_name": "streamwise wind component"}),
            "v_ms": (("sensor", "time"), data["v_ms"], {"units": "m s-1", "long_name": "cross-stream wind component"}),
            "w_ms": (("sensor", "time"), data["w_ms"], {"units": "m s-1", "long_name": "vertical wind component"}),
            "theta_v_k": (("sensor", "time"), data["theta_v_k"],
                          {"units": "K", "standard_name": "virtual_temperature"}),
            "wind_from_deg": (("sensor",), np.array([spec.wind_from_deg + 3.0, spec.wind_from_deg]),
                              {"units": "degree", "standard_name": "wind_from_direction"}),
            "height_m": (("sensor",), np.array([spec.drone_height_m, spec.mast_height_m]),
                         {"units": "m", "standard_name": "height", "positive": "up"}),
            "rotation_yaw_deg": (("sensor",), np.array([0.0, 0.0]), {"units": "degree", "long_name": "yaw"}),
            "rotation_pitch_deg": (("sensor",), np.array([0.5, 0.1]), {"units": "degree", "long_name": "pitch"}),
            "rotation_roll_deg": (("sensor",), np.array([0.0, 0.0]), {"units": "degree", "long_name": "roll"}),
            "lag_s": (("lag",), lag_grid, {"units": "s", "long_name": "drone-mast lag"}),
            "xcorr": (("lag",), xcorr, {"units": "1", "long_name": "cross-correlation"}),
        },
        coords={"sensor": ("sensor", np.array(["drone", "mast"])), "time": ("time", time), "lag": ("lag", lag_grid)},
    )
    ds["lag"].attrs.update(units="s", long_name="drone-mast lag added to the drone time stamps")
    ds["u_ms"].attrs.update(standard_name="x_wind")
    ds["v_ms"].attrs.update(standard_name="y_wind")
    ds["w_ms"].attrs.update(standard_name="upward_air_velocity")
    ds.attrs.update(
        lag_drone_mast_s=spec.lag_drone_mast_s, rotation_method="double", sampling_rate_hz=FS_L3_HZ,
        n_samples=n, lag_sonic_ins_s=spec.lag_sonic_ins_s, drone_usable=int(spec.usable),
        drone_unusable_reason=spec.unusable_reason,
    )
    return ds


def _drone_l2(spec: FlightSpec, mast_lat: float, mast_lon: float, rng: np.random.Generator) -> xr.Dataset:
    n = int(spec.minutes * 60 * FS_L2_HZ)
    time = (np.datetime64(spec.start, "ns") + (np.arange(n) * (1e9 / FS_L2_HZ)).astype("timedelta64[ns]"))
    t = np.arange(n) / FS_L2_HZ
    east = spec.offset_east_m + 1.5 * np.sin(2 * np.pi * t / 90.0) + 0.3 * rng.standard_normal(n)
    north = spec.offset_north_m + 1.5 * np.cos(2 * np.pi * t / 70.0) + 0.3 * rng.standard_normal(n)
    m_per_deg = 111_195.0
    lat = mast_lat + north / m_per_deg
    lon = mast_lon + east / (m_per_deg * np.cos(np.deg2rad(mast_lat)))
    alt = SITE["altitude_m"] + spec.drone_height_m + 0.8 * np.sin(2 * np.pi * t / 120.0) + 0.2 * rng.standard_normal(n)
    lag_grid = np.arange(-64, 65) / 32.0
    tke = 1.0 * (1.0 + 0.08 * (lag_grid - spec.lag_sonic_ins_s) ** 2 + 0.01 * np.abs(lag_grid - spec.lag_sonic_ins_s))
    speed = spec.speed_ms
    wdir = np.deg2rad(spec.wind_from_deg)
    ds = xr.Dataset(
        {
            "u_east_ms": (("time",), -speed * np.sin(wdir) + rng.standard_normal(n), {"units": "m s-1",
                                                                                     "standard_name": "eastward_wind"}),
            "v_north_ms": (("time",), -speed * np.cos(wdir) + rng.standard_normal(n),
                           {"units": "m s-1", "standard_name": "northward_wind"}),
            "w_up_ms": (("time",), 0.5 * rng.standard_normal(n), {"units": "m s-1",
                                                                  "standard_name": "upward_air_velocity"}),
            "t_sonic_k": (("time",), 290.0 + 0.2 * rng.standard_normal(n), {"units": "K",
                                                                            "standard_name": "virtual_temperature"}),
            "roll_deg": (("time",), rng.standard_normal(n), {"units": "degree", "standard_name": "platform_roll"}),
            "pitch_deg": (("time",), rng.standard_normal(n), {"units": "degree", "standard_name": "platform_pitch"}),
            "yaw_deg": (("time",), (spec.wind_from_deg + rng.standard_normal(n)) % 360,
                        {"units": "degree", "standard_name": "platform_yaw"}),
            "precise_lat": (("time",), lat, {"units": "degrees_north", "standard_name": "latitude"}),
            "precise_lon": (("time",), lon, {"units": "degrees_east", "standard_name": "longitude"}),
            "altitude": (("time",), alt, {"units": "m", "standard_name": "altitude", "positive": "up"}),
            "qc_sonic": (("time",), np.zeros(n, np.int32), {"standard_name": "status_flag",
                                                            "flag_masks": np.array([1, 2, 4, 8], np.int32),
                                                            "flag_meanings": "out_of_range spike missing gap_filled"}),
            "lag_s": (("lag",), lag_grid, {"units": "s", "long_name": "sonic-INS lag added to the sonic clock"}),
            "tke_m2s2": (("lag",), tke, {"units": "m2 s-2",
                                         "standard_name": "specific_turbulent_kinetic_energy_of_air"}),
        },
        coords={"time": ("time", time), "lag": ("lag", lag_grid)},
    )
    ds["lag"].attrs.update(units="s", long_name="sonic-INS lag added to the sonic clock")
    ds.attrs.update(
        lag_sonic_ins_s=spec.lag_sonic_ins_s, usable=int(spec.usable), unusable_reason=spec.unusable_reason,
        height_m=float(np.median(alt) - SITE["altitude_m"]), target_height_m=spec.mast_height_m,
        sampling_rate_hz=FS_L2_HZ,
    )
    return ds


def _mast_l2(spec: FlightSpec, rng: np.random.Generator) -> xr.Dataset:
    n = int(spec.minutes * 60 * FS_MAST_HZ)
    time = np.datetime64(spec.start, "ns") + (np.arange(n) * (1e9 / FS_MAST_HZ)).astype("timedelta64[ns]")
    wdir = np.deg2rad(spec.wind_from_deg)
    return xr.Dataset(
        {
            "u_east_ms": (("time",), -spec.speed_ms * np.sin(wdir) + rng.standard_normal(n),
                          {"units": "m s-1", "standard_name": "eastward_wind"}),
            "v_north_ms": (("time",), -spec.speed_ms * np.cos(wdir) + rng.standard_normal(n),
                           {"units": "m s-1", "standard_name": "northward_wind"}),
            "w_up_ms": (("time",), 0.5 * rng.standard_normal(n), {"units": "m s-1",
                                                                  "standard_name": "upward_air_velocity"}),
            "t_sonic_k": (("time",), 290.0 + 0.2 * rng.standard_normal(n),
                          {"units": "K", "standard_name": "virtual_temperature"}),
        },
        coords={"time": ("time", time)},
        attrs={"sampling_rate_hz": FS_MAST_HZ, "height_m": spec.mast_height_m},
    )


def manifest_dict(name: str) -> dict:
    """The campaign manifest of the fixture (a virtual campaign: files need not exist)."""
    return {
        "name": name,
        "site": dict(SITE),
        "masts": [{
            "id": "p2oa", "latitude": SITE["latitude"], "longitude": SITE["longitude"],
            "sonics": [
                {"id": "mast30", "height_m": 30, "model": "CSAT3", "azimuth_deg": 218.0, "files": ["mast/m30_*.dat"]},
                {"id": "mast60", "height_m": 60, "model": "CSAT3", "azimuth_deg": 230.5, "files": ["mast/m60_*.dat"]},
            ],
        }],
        "payload_flights": [
            {"id": s.flight, "reference": s.reference, "target_height_m": s.mast_height_m,
             "sonic": {"file": f"flights/{s.flight}/sonic.csv", "mount": "upside_down"},
             "ins": {"file": f"flights/{s.flight}/ins.csv"}}
            for s in FLIGHTS
        ],
        "simulation": {"seed": 0, "note": "products fixture for table and figure tests"},
    }


def write_products(folder: Path, name: str = "fixcamp", seed: int = 0) -> Path:
    """Write the products tree of a 4-flight synthetic campaign.

    Parameters
    ----------
    folder : Path
        Folder that receives ``<name>.yaml`` and ``results/<name>/``.
    name : str
        Campaign name.
    seed : int
        Seed of the synthetic series.

    Returns
    -------
    Path
        ``folder / "results" / name`` (holds ``netcdf/``, ``tables/``, ``campaign.json``).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    manifest = folder / f"{name}.yaml"
    manifest.write_text(yaml.safe_dump(manifest_dict(name), sort_keys=False))
    root = folder / "results" / name
    config: dict = {}
    pipeline.campaign_record(manifest, root / "campaign.json", config)
    rng = np.random.default_rng(seed)
    sonics = load_campaign(manifest).mast_sonics()
    proc = default_config()["processing"]
    l4_files = []
    for spec in FLIGHTS:
        l2_dir, l3_dir, l4_dir = (root / "netcdf" / lvl for lvl in ("L2", "L3", "L4"))
        drone = _drone_l2(spec, SITE["latitude"], SITE["longitude"], rng)
        d_root, d_groups = split_standard(drone, "synchronisation")
        drone_file = write_netcdf(
            d_root, l2_dir / f"{spec.flight}_drone.nc", title=f"{name} flight {spec.flight}: drone wind, L2",
            summary="synthetic", processing_level="L2", history="products_fixture", config=config,
            station_id=f"{spec.flight}_drone", latitude=float(np.median(drone["precise_lat"])),
            longitude=float(np.median(drone["precise_lon"])), height_m=float(drone.attrs["height_m"]),
            extra_attrs={"campaign": name, "flight": spec.flight}, groups=d_groups,
        )
        mast_file = write_netcdf(
            _mast_l2(spec, rng), l2_dir / f"{spec.flight}_mast.nc", title=f"{name} flight {spec.flight}: mast, L2",
            summary="synthetic", processing_level="L2", history="products_fixture", config=config,
            station_id=spec.reference, latitude=SITE["latitude"], longitude=SITE["longitude"],
            height_m=spec.mast_height_m, extra_attrs={"campaign": name, "flight": spec.flight},
        )
        l3 = _l3_dataset(spec, name, rng)
        r3, g3 = split_standard(l3, "alignment")
        l3_file = write_netcdf(
            r3, l3_dir / f"{spec.flight}.nc", title=f"{name} flight {spec.flight}: drone and mast aligned, L3",
            summary="synthetic", processing_level="L3", history="products_fixture", inputs=[drone_file, mast_file],
            config=config, station_id=f"{spec.flight}_drone_and_mast", latitude=SITE["latitude"],
            longitude=SITE["longitude"], height_m=spec.mast_height_m,
            extra_attrs={"campaign": name, "flight": spec.flight, "reference": spec.reference}, groups=g3,
        )
        for sensor in ("drone", "mast"):
            l4_files.append(pipeline.l4(l3_file, l4_dir / f"{spec.flight}_{sensor}.nc", campaign=name,
                                        flight_id=spec.flight, sensor=sensor, reference=sonics[spec.reference],
                                        spectra=proc["spectra"], quadrant=proc["quadrant"],
                                        detrending=proc["detrending"]))
    pipeline.flight_stats(l4_files, root / "tables" / "flight_stats.csv")
    return root


def set_nan(path: Path, name: str) -> None:
    """Overwrite a stored variable with NaN in place (root group or any sub-group)."""
    with netCDF4.Dataset(path, "a") as nc:
        for grp in (nc, *nc.groups.values()):
            if name in grp.variables:
                grp[name][...] = np.nan
                return
    raise KeyError(name)
