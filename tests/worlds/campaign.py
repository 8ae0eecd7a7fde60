"""Truths and the campaign writer of the independent world.

A truth is a :class:`dronewind.diagnose.experiments.Draw` (so that
:func:`dronewind.diagnose.experiments.judge` can judge it): a catalog mechanism with the
sizes of :data:`dronewind.diagnose.experiments.HIDDEN_RANGES` (both sides where the
parameter has two), nothing, or a model error of this world (``model_error`` holds its
settings under ``"world"``). The mechanisms act inside this world's physics with the
catalog's meaning and signs (docs/data-contract.md, "Mechanisms" and "Frames and signs"):

* ``sonic_ins_lag`` lag_s: a sonic sample taken at t is stamped t - lag_s on the logger
  clock (lag_s is what must be added to the sonic's clock to align it with the INS);
* ``clock_drift`` ppm: the sonic's stamps run fast, t + ppm 1e-6 (t - t_first);
* ``heading_bias`` deg: INS yaw = true yaw + deg;
* ``attitude_lag`` lag_s: INS attitude at t = true attitude at t - lag_s;
* ``mount_misalignment`` pitch_deg: the true sensor-to-body rotation is M_mount R(0, pitch, 0);
* ``w_gain`` gain: the sonic's w (sensor frame) times gain;
* ``sonic_noise`` sigma_ms: white noise of that standard deviation on each sonic component;
* ``mast_w_attenuation`` gain: the mast sonic's Uz times gain.

Every flight also has a sonic-INS processing lag, NOT a hidden effect: its stamps are
shifted like ``sonic_ins_lag`` by a per-flight draw in [-0.185, 0] s (Ghirardelli et al.
2025, Fig. 4: the minima of the TKE-versus-lag curves of their ten flights lie there), or
in the ``symmetric`` variant by 0.05-0.15 s of either sign. The per-flight values go to
the truth file beside the manifest, never into the manifest.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from dronewind.diagnose.experiments import HIDDEN_RANGES, Draw, _hidden_parameters
from tests.worlds import files, ins, pendulum, turbulence

#: Catalog mechanisms this world hides (each on both sides where signed).
HIDDEN_MECHANISMS: tuple[str, ...] = ("attitude_lag", "clock_drift", "heading_bias", "mast_w_attenuation",
                                      "mount_misalignment", "sonic_ins_lag", "sonic_noise", "w_gain")

#: Model errors of this world: name -> setting -> choices (ranges, one drawn, then a value in it).
#: Physics outside the catalog; the correct verdict names nothing.
WORLD_MODEL_ERRORS: dict[str, dict[str, tuple[tuple[float, float], ...]]] = {
    # Mann's anisotropy: Gamma 3.9 by default; 1.2-2 (nearly isotropic, unstable air) or
    # 5-6 (strongly sheared) (Peña et al. 2010 fitted 2-4 over land)
    "mann_gamma": {"gamma": ((1.2, 2.0), (5.0, 6.0))},
    # the mean wind changing over the hover (fronts, transitions)
    "mean_wind_trend": {"speed_trend_ms_per_h": ((-3.0, -1.5), (1.5, 3.0)),
                        "direction_trend_deg_per_h": ((-40.0, -20.0), (20.0, 40.0))},
    # the mast sonic in its tower's flow: a speed deficit and a streamline tilt
    "mast_flow_distortion": {"speed_deficit": ((0.04, 0.08),), "tilt_deg": ((-5.0, -2.0), (2.0, 5.0))},
    # another line: shorter or longer than 18 m, with 2-4 times the drag
    "rope": {"length_m": ((10.0, 13.0), (26.0, 32.0)), "drag_factor": ((2.0, 4.0),)},
}

#: Base (not hidden) sonic-INS lag variants: name -> (low, high, signed) [s].
BASE_LAGS: dict[str, tuple[float, float, bool]] = {"paper": (-0.185, 0.0, False), "symmetric": (0.05, 0.15, True)}

_EPOCH = np.datetime64("1970-01-01T00:00:00", "us")


@dataclass(frozen=True)
class WorldSettings:
    """Campaign layout and world constants.

    Attributes
    ----------
    n_flights : int
        Payload flights (one hour apart).
    hover_s : float
        Hover window of each flight (the manifest's ``window``) [s].
    pre_s, post_s : float
        Logging before and after the window [s] (GNSS start-up at the beginning).
    mast_margin_s : float
        Mast record before and after the window [s].
    base_lag : str
        Key of :data:`BASE_LAGS`.
    speeds_ms : tuple of (float, float)
        Ranges of the flights' mean wind at 30 m, cycled (up to 9.5 m/s: above about 10 m/s
        the payload's gust-driven swing leaves the chain's 4 m hover tolerance for more than
        the 10 minutes a flight needs, and the flight is rightly marked unusable).
    nx : int
        Along-wind points of the Mann box (16 crosswind, 12 vertical at 4 m).
    line : pendulum.LineSettings
    ins_errors : ins.InsErrors
    inertial_topup : bool
        Each sensor's record gets the inertial subrange the box's coarse grid lacks above
        about 1 Hz (:meth:`turbulence.WindField.topup_enu`); off: the box alone.
    """

    n_flights: int = 4
    hover_s: float = 720.0
    pre_s: float = 90.0
    post_s: float = 30.0
    mast_margin_s: float = 120.0
    base_lag: str = "paper"
    speeds_ms: tuple[tuple[float, float], ...] = ((3.0, 5.0), (5.0, 6.5), (6.5, 8.0), (8.0, 9.5))
    nx: int = 16384
    line: pendulum.LineSettings = field(default_factory=pendulum.LineSettings)
    ins_errors: ins.InsErrors = field(default_factory=ins.InsErrors)
    inertial_topup: bool = False


SITE = {"name": "independent world", "latitude": 45.2, "longitude": 5.7, "altitude_m": 410.0}
MAST = {"id": "tower", "sonic": "mast30", "height_m": 30.0, "azimuth_deg": 218.0}
SONIC_HZ, INS_HZ, MAST_HZ, FORCING_HZ, STATE_HZ = 32.0, 50.0, 20.0, 20.0, 100.0


def model_error_world_draw(rng: np.random.Generator, name: str) -> Draw:
    """A model-error truth of this world (settings under ``model_error["world"]``)."""
    seed = int(rng.integers(1, 2**31 - 1))
    settings = {}
    for key, choices in WORLD_MODEL_ERRORS[name].items():
        lo, hi = choices[int(rng.integers(len(choices)))]
        settings[key] = round(float(rng.uniform(lo, hi)), 3)
    return Draw("none", {}, seed, {"world": settings}, name)


def stratified_world_draws(n: int, seed: int, null_share: float = 0.2, model_error_share: float = 0.2
                           ) -> list[Draw]:
    """``n`` truths: nulls, model errors (cycling :data:`WORLD_MODEL_ERRORS`), then hidden
    mechanisms cycling the cells (mechanism, side) of :data:`HIDDEN_MECHANISMS` in a seeded
    order (so that a short run meets different mechanisms). Draw ``k`` uses
    ``numpy.random.default_rng([seed, k])``."""
    n_null = int(round(null_share * n))
    n_model = int(round(model_error_share * n))
    cells: list[tuple[str, int | None]] = []
    for mech in HIDDEN_MECHANISMS:
        signed = any(s for _, _, s in HIDDEN_RANGES[mech].values())
        cells += [(mech, 1), (mech, -1)] if signed else [(mech, None)]
    order = np.random.default_rng([seed, 10**6]).permutation(len(cells))
    kinds = sorted(WORLD_MODEL_ERRORS)
    out: list[Draw] = []
    for k in range(n):
        rng = np.random.default_rng([seed, k])
        if k < n_null:
            out.append(Draw("none", {}, int(rng.integers(1, 2**31 - 1))))
        elif k < n_null + n_model:
            out.append(model_error_world_draw(rng, kinds[(k - n_null) % len(kinds)]))
        else:
            mech, sign = cells[int(order[(k - n_null - n_model) % len(cells)])]
            draw_seed = int(rng.integers(1, 2**31 - 1))
            out.append(Draw(mech, _hidden_parameters(rng, mech, sign), draw_seed))
    return out


def _flight_conditions(rng: np.random.Generator, i: int, settings: WorldSettings) -> dict[str, float]:
    """Conditions of flight ``i``. The hover point lies 5-15 m up- or downwind of the mast and
    up to 10 m across: the chain searches the drone-mast lag within 6 s, which 15 m at 3 m/s
    stays inside."""
    lo, hi = settings.speeds_ms[i % len(settings.speeds_ms)]
    lo_lag, hi_lag, signed = BASE_LAGS[settings.base_lag]
    base = float(rng.uniform(lo_lag, hi_lag)) * (float(rng.choice([-1.0, 1.0])) if signed else 1.0)
    return {"speed_ms": float(rng.uniform(lo, hi)), "wind_from_deg": float(rng.uniform(170.0, 300.0)),
            "zeta": float(rng.uniform(-0.4, 0.1)), "z0_m": float(rng.uniform(0.02, 0.1)),
            "payload_height_m": float(rng.uniform(28.0, 31.0)), "along_m": float(rng.choice([-1, 1]) *
                                                                                   rng.uniform(5.0, 15.0)),
            "cross_m": float(rng.uniform(-10.0, 10.0)), "theta_k": float(rng.uniform(285.0, 300.0)),
            "base_lag_s": round(base, 4), "boot_s": float(rng.uniform(200.0, 3000.0)),
            "logger_drift_ppm": float(rng.uniform(-20.0, 20.0)), "gnss_valid_s": float(rng.uniform(20.0, 45.0)),
            "yaw_wrap_180": float(rng.random() < 0.5)}


def write_campaign(truth: Draw, folder: str | Path, settings: WorldSettings = WorldSettings(),
                   name: str = "world") -> Path:
    """Write a measured campaign hiding ``truth`` into ``folder``; return the manifest path.

    Beside the manifest, ``truth.json`` holds the truth and each flight's conditions
    (including its base sonic-INS lag); the pipeline reads only the manifest and its files.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    world = dict(truth.model_error.get("world", {}))
    line = settings.line
    if truth.model_error_name == "rope":
        line = replace(line, length_m=world["length_m"], payload_cda_m2=line.payload_cda_m2 * world["drag_factor"],
                       line_cd=line.line_cd * world["drag_factor"])
    mech = {} if truth.mechanism == "none" else {truth.mechanism: dict(truth.parameters)}
    flights, record = [], {"truth": asdict(truth), "settings": {"base_lag": settings.base_lag,
                                                                 "line_length_m": line.length_m}, "flights": {}}
    for i in range(settings.n_flights):
        fid = f"w{i + 1:02d}"
        rng = np.random.default_rng([truth.seed, i])
        cond = _flight_conditions(rng, i, settings)
        start = np.datetime64("2024-05-14T09:00:00", "us") + np.timedelta64(3600 * i, "s")
        end = start + np.timedelta64(int(settings.hover_s * 1e6), "us")
        _write_flight(folder, fid, cond, start, settings, line, mech, world, rng)
        record["flights"][fid] = cond
        flights.append({"id": fid, "reference": MAST["sonic"], "target_height_m": 30,
                        "sonic": {"file": f"flights/{fid}/sonic.csv", "mount": fid_mount(fid)},
                        "ins": {"file": f"flights/{fid}/ins.csv"},
                        "window": {"start": f"{start.astype('datetime64[s]')}Z",
                                   "end": f"{end.astype('datetime64[s]')}Z"}})
    manifest = {"name": name, "site": dict(SITE),
                "masts": [{"id": MAST["id"], "latitude": SITE["latitude"], "longitude": SITE["longitude"],
                           "sonics": [{"id": MAST["sonic"], "height_m": MAST["height_m"], "model": "CSAT3",
                                       "azimuth_deg": MAST["azimuth_deg"], "files": ["mast/mast30_*.dat"]}]}],
                "payload_flights": flights}
    (folder / "truth.json").write_text(json.dumps(record, indent=1, default=float))
    return files.write_manifest(folder / "campaign.yaml", manifest)


def build_field(cond: dict[str, float], settings: WorldSettings, world: dict[str, float], seed: int,
                duration_s: float, top_m: float = 50.0) -> turbulence.WindField:
    """The flight's wind: log profile, Mann box scaled to the Panofsky sigma_u, heat flux of its Obukhov length."""
    z = MAST["height_m"]
    ell = z / cond["zeta"] if cond["zeta"] != 0 else math.inf
    ustar = turbulence.friction_velocity_ms(cond["speed_ms"], z, cond["z0_m"], ell)
    sig_u = turbulence.sigma_u_ms(ustar, ell)
    span = cond["speed_ms"] * duration_s + 2 * abs(cond["along_m"]) + 200.0
    dx = max(span / settings.nx, 0.05)
    nz = max(12, int(math.ceil((top_m - 6.0) / 4.0)) + 2)
    nxyz, dxyz = (settings.nx, 16, nz + nz % 2), (dx, 4.0, 4.0)      # hipersim wants even sizes
    uvw = turbulence.mann_box(turbulence.mann_length_m(z, cond["zeta"]), world.get("gamma", 3.9), sig_u, nxyz,
                              dxyz, seed)
    a, b = turbulence.heat_gains(ustar, ell, cond["theta_k"], float(uvw[2].std()), float(uvw[1].std()))
    topup = turbulence.inertial_deficit(*turbulence.box_spectra(uvw, dx)) if settings.inertial_topup else None
    return turbulence.WindField(uvw=uvw, dxyz_m=dxyz, z_bottom_m=6.0, y_centre_m=32.0,
                                x_offset_m=abs(cond["along_m"]) + 50.0, speed_ms=cond["speed_ms"],
                                wind_from_deg=cond["wind_from_deg"], z_ref_m=z, ustar_ms=ustar, z0_m=cond["z0_m"],
                                obukhov_m=ell, speed_trend_ms_per_s=world.get("speed_trend_ms_per_h", 0.0) / 3600,
                                direction_trend_deg_per_s=world.get("direction_trend_deg_per_h", 0.0) / 3600,
                                theta_k=cond["theta_k"], heat_w_gain_k_per_ms=a, heat_v_gain_k_per_ms=b,
                                topup=topup)


def _logger_us(t_s: np.ndarray, cond: dict[str, float]) -> np.ndarray:
    return np.round((cond["boot_s"] + t_s * (1 + cond["logger_drift_ppm"] * 1e-6)) * 1e6).astype(np.int64)


def _write_flight(folder: Path, fid: str, cond: dict[str, float], start: np.datetime64, settings: WorldSettings,
                  line: pendulum.LineSettings, mech: dict[str, dict[str, float]], world: dict[str, float],
                  rng: np.random.Generator) -> None:
    """One flight: field, pendulum, sonic, INS and the mast's record (t = 0 at the mast record's start)."""
    m0 = settings.mast_margin_s
    duration = settings.hover_s + 2 * m0
    t0_utc = start - np.timedelta64(int(m0 * 1e6), "us")
    wf = build_field(cond, settings, world, int(rng.integers(1, 2**31 - 1)), duration,
                     cond["payload_height_m"] + line.length_m + 2.0)
    a = math.radians(cond["wind_from_deg"])
    ex = np.array([-math.sin(a), -math.cos(a)])
    ey = np.array([math.cos(a), -math.sin(a)])
    set_en = cond["along_m"] * ex + cond["cross_m"] * ey                    # hover set point (east, north)
    hook_up = cond["payload_height_m"] + line.length_m
    # --- forcing tables and the pendulum over the payload's record
    t_a, t_b = m0 - settings.pre_s, m0 + settings.hover_s + settings.post_s
    tf = np.arange(t_a - 60.0, t_b + 1.0, 1.0 / FORCING_HZ)            # 60 s settling before logging
    sig = turbulence.sigma_u_ms(wf.ustar_ms, wf.obukhov_m)
    jitter = pendulum.hook_motion(tf, rng, 0.15 + 0.1 * sig, 0.1 + 0.05 * sig)
    hook = np.concatenate([jitter(tf), jitter(tf, 1), jitter(tf, 2)], axis=1)
    hook[:, 0] += set_en[0]
    hook[:, 1] += set_en[1]
    hook[:, 2] += hook_up
    frac = (np.arange(line.n_segments) + 0.5) / line.n_segments
    def nominal(east: np.ndarray, north: np.ndarray, up: float) -> tuple[np.ndarray, np.ndarray, float]:
        """Turbulence place of a moving point: its along-wind place, the set point across, ``up``."""
        along = (east - set_en[0]) * ex[0] + (north - set_en[1]) * ex[1]
        return set_en[0] + along * ex[0], set_en[1] + along * ex[1], up

    wind_p, _ = wf.sample(tf, hook[:, 0], hook[:, 1], hook[:, 2] - line.length_m,
                          nominal(hook[:, 0], hook[:, 1], cond["payload_height_m"]))
    wind_l = np.stack([wf.sample(tf, hook[:, 0], hook[:, 1], hook[:, 2] - f * line.length_m,
                                 nominal(hook[:, 0], hook[:, 1], hook_up - f * line.length_m))[0]
                       for f in frac], axis=1)
    heading = np.radians(cond["wind_from_deg"] + 1.0 * np.sin(2 * np.pi * tf / 97.0))   # drone faces the wind
    ts_state = np.arange(tf[0], tf[-1] - 0.5, 1.0 / STATE_HZ)
    states = pendulum.solve_pendulum(line, tf, hook, wind_p, wind_l, heading, ts_state)
    keep = ts_state >= t_a - 2.0
    ts_state, states = ts_state[keep], states[keep]

    def payload_at(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity (east, north, up) and body axes of the payload at times t."""
        r = np.stack([np.interp(t, ts_state, states[:, k]) for k in range(8)], axis=1)
        pos = jitter(t) + np.array([set_en[0], set_en[1], hook_up]) + r[:, 0:3]
        vel = jitter(t, 1) + r[:, 3:6]
        return pos, vel, pendulum.body_axes_enu(r[:, 0:3], r[:, 6])

    # --- payload sonic
    n_s = int((t_b - t_a) * SONIC_HZ)
    t_s = t_a + np.arange(n_s) / SONIC_HZ
    pos, vel, axes = payload_at(t_s)
    wind, theta = wf.sample(t_s, pos[:, 0], pos[:, 1], pos[:, 2],
                            nominal(pos[:, 0], pos[:, 1], cond["payload_height_m"]))
    # the inertial subrange the box lacks, independent at each sensor (a stream of its own, drawn
    # only when asked for, so that the other streams stay as they were without it)
    topup_rng = np.random.default_rng(int(rng.integers(1, 2**31 - 1))) if wf.topup is not None else None
    if topup_rng is not None:
        wind = wind + wf.topup_enu(topup_rng, n_s, SONIC_HZ)
    rel_enu = wind - vel
    v_body = np.einsum("nji,nj->ni", axes, rel_enu)                     # axes^T rel: body components
    mount = np.eye(3) if fid_mount(fid) == "upside_down" else np.diag([1.0, -1.0, -1.0])
    m_true = mount
    if "mount_misalignment" in mech:
        mm = mech["mount_misalignment"]
        m_true = mount @ pendulum.body_to_ned(mm.get("roll_deg", 0.0), mm["pitch_deg"], mm.get("yaw_deg", 0.0))
    v_sensor = v_body @ m_true                                           # (M^T v) row-wise
    if "w_gain" in mech:
        v_sensor[:, 2] *= mech["w_gain"]["gain"]
    v_sensor += 0.02 * rng.standard_normal(v_sensor.shape)
    if "sonic_noise" in mech:
        v_sensor += mech["sonic_noise"]["sigma_ms"] * rng.standard_normal(v_sensor.shape)
    t_c = theta - 9.81 / 1004.0 * pos[:, 2] - 273.15 + 0.02 * rng.standard_normal(n_s)
    stamp = t_s - cond["base_lag_s"] - mech.get("sonic_ins_lag", {}).get("lag_s", 0.0)
    if "clock_drift" in mech:
        stamp = stamp + mech["clock_drift"]["ppm"] * 1e-6 * (t_s - t_s[0])
    rows = np.arange(n_s)
    rows = rows[rng.random(n_s) > 0.002]                                 # serial dropouts
    dup = rng.choice(rows, size=max(1, rows.size // 2000), replace=False)
    rows = np.sort(np.concatenate([rows, dup]))                          # a few repeated lines
    files.write_sonic_csv(folder / "flights" / fid / "sonic.csv", _logger_us(stamp[rows], cond),
                          np.round(v_sensor[rows], 2), np.round(t_c[rows], 2))
    # --- INS
    n_i = int((t_b - t_a) * INS_HZ)
    t_i = t_a + np.arange(n_i) / INS_HZ
    pos_i, vel_i, _ = payload_at(t_i)
    _, _, axes_i = payload_at(t_i - mech.get("attitude_lag", {}).get("lag_s", 0.0))
    att = pendulum.euler_deg(axes_i) + ins.attitude_errors_deg(rng, n_i, 1 / INS_HZ, settings.ins_errors)
    att[:, 2] += mech.get("heading_bias", {}).get("deg", 0.0)
    yaw = att[:, 2] % 360.0
    if cond["yaw_wrap_180"]:
        yaw = np.where(yaw > 180.0, yaw - 360.0, yaw)
    dvel = ins.velocity_errors_ms(rng, n_i, 1 / INS_HZ, settings.ins_errors)
    dpos = ins.position_errors_m(rng, n_i, 1 / INS_HZ, settings.ins_errors)
    lat, lon = files.enu_to_latlon(pos_i[:, 0] + dpos[:, 0], pos_i[:, 1] + dpos[:, 1], SITE["latitude"],
                                   SITE["longitude"])
    since = t_i - t_a
    valid = ins.gnss_time_valid(since, cond["gnss_valid_s"], (8.0, 9.5))
    files.write_ins_csv(folder / "flights" / fid / "ins.csv", {
        "rpi_time_us": _logger_us(t_i, cond), "utc": t0_utc + np.round(t_i * 1e6).astype("timedelta64[us]"),
        "time_valid": valid, "ekf_valid": (since >= 5.0).astype(int), "lat_deg": lat, "lon_deg": lon,
        "alt_m": SITE["altitude_m"] + pos_i[:, 2] + dpos[:, 2],
        "vel_n_ms": vel_i[:, 1] + dvel[:, 0], "vel_e_ms": vel_i[:, 0] + dvel[:, 1],
        "vel_d_ms": -vel_i[:, 2] + dvel[:, 2], "roll_deg": att[:, 0], "pitch_deg": att[:, 1], "yaw_deg": yaw})
    # --- mast CSAT3 at the mast foot's vertical, 30 m
    n_m = int(duration * MAST_HZ)
    t_m = np.arange(n_m) / MAST_HZ
    wind_m, theta_m = wf.sample(t_m, 0.0, 0.0, MAST["height_m"])
    if topup_rng is not None:
        wind_m = wind_m + wf.topup_enu(topup_rng, n_m, MAST_HZ)
    if "speed_deficit" in world:                                          # tower flow distortion
        d, tilt = world["speed_deficit"], math.radians(world["tilt_deg"])
        wind_m[:, :2] *= 1.0 - d
        horiz = np.hypot(wind_m[:, 0], wind_m[:, 1])
        wind_m[:, 2] = wind_m[:, 2] * math.cos(tilt) + horiz * math.sin(tilt)
    alpha = math.radians(MAST["azimuth_deg"])
    ux = -wind_m[:, 0] * math.sin(alpha) - wind_m[:, 1] * math.cos(alpha)
    uy = wind_m[:, 0] * math.cos(alpha) - wind_m[:, 1] * math.sin(alpha)
    uz = wind_m[:, 2] * mech.get("mast_w_attenuation", {}).get("gain", 1.0)
    ux, uy, uz = (c + 0.01 * rng.standard_normal(n_m) for c in (ux, uy, uz))
    ts_m = theta_m - 9.81 / 1004.0 * MAST["height_m"] - 273.15 + 0.02 * rng.standard_normal(n_m)
    diag = np.zeros(n_m, dtype=int)
    bad = rng.random(n_m) < 5e-4
    diag[bad] = 1
    for arr in (ux, uy, uz, ts_m):
        arr[bad] = np.nan
    files.write_toa5(folder / "mast" / f"mast30_{fid}.dat", t0_utc + np.round(t_m * 1e6).astype("timedelta64[us]"),
                     1000 + np.arange(n_m), ux, uy, uz, ts_m, diag)


def fid_mount(fid: str) -> str:
    """The sonic's mount of flight ``fid``: upside down on odd flights, upright on even ones."""
    return "upside_down" if int(fid[1:]) % 2 == 1 else "upright"
