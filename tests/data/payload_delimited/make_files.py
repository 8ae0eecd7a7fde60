"""Write the example payload pair twice: in the contract CSVs and in a logger's own layout.

The same samples (seeded) in both layouts, so that the L1 of the two must agree
(``tests/test_payload_delimited.py``). The own layout is what a SAMURAI-S-type payload with
another logger might write: the sonic semicolon-separated with a comment line and a units
line, the logger clock in milliseconds, velocities in cm/s with the sonic's x and y swapped
and its z pointing down, the temperature in kelvin; the INS tab-separated and gzipped, GNSS
UTC as seconds since 1970, a fix status instead of a 0/1 flag, angles and position in
radians, the velocity as east, north, up. Both pairs hold one duplicated sonic row, one
"NAN" sample and one truncated line. Run from the repository root:
``python tests/data/payload_delimited/make_files.py``.
"""

from __future__ import annotations

import datetime as dt
import gzip
import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
SONIC_HZ, INS_HZ, DURATION_S = 32.0, 25.0, 30.0
RPI0_US = 7_312_004_113  # logger clock at the INS's first row [us]
UTC0 = dt.datetime(2023, 8, 21, 14, 5, 30, 250_000)
DRIFT = 18e-6  # logger clock runs slow by 18 ppm


def main() -> None:
    rng = np.random.default_rng(20230821)
    # INS rows
    n_ins = int(DURATION_S * INS_HZ)
    t_ins = RPI0_US + np.arange(n_ins) * 40_000 + rng.integers(-300, 300, n_ins)
    ins_rows_c, ins_rows_o = [], []
    for k, t in enumerate(t_ins):
        valid = k >= 50  # no GNSS time for the first 2 s
        utc = UTC0 + dt.timedelta(microseconds=int(round((t - RPI0_US) * (1 + DRIFT))))
        lat, lon = 43.1247 + 1e-6 * float(rng.normal()), 0.3628 + 1e-6 * float(rng.normal())
        alt = round(633.0 + 0.3 * math.sin(k / 40), 3)
        vn, ve, vd = (round(float(x), 4) for x in 0.1 * rng.normal(size=3))
        roll, pitch = (round(float(x), 4) for x in 2 * rng.normal(size=2))
        yaw = round(12.0 + 3 * math.sin(k / 90), 4)
        lat, lon = round(lat, 7), round(lon, 7)
        utc_text = utc.strftime("%Y-%m-%dT%H:%M:%S.%fZ") if valid else ""
        ins_rows_c.append(f"{t},{utc_text},{int(valid)},1,{lat},{lon},{alt},{vn},{ve},{vd},{roll},{pitch},{yaw}")
        epoch = utc.replace(tzinfo=dt.UTC) - dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
        utc_own = f"{epoch.days * 86400 + epoch.seconds}.{epoch.microseconds:06d}" if valid else ""
        ins_rows_o.append("\t".join([f"{t // 1000}.{t % 1000:03d}", utc_own, "3" if valid else "0", "2",
                                     repr(math.radians(lat)), repr(math.radians(lon)), repr(alt), repr(ve),
                                     repr(vn), repr(-vd), repr(math.radians(roll)), repr(math.radians(pitch)),
                                     repr(math.radians(yaw))]))
    # sonic rows
    n_sonic = int(DURATION_S * SONIC_HZ)
    t_sonic = RPI0_US + 90_000 + np.arange(n_sonic) * 31_250
    u = 3.0 + 0.5 * rng.normal(size=n_sonic)
    v = -1.0 + 0.5 * rng.normal(size=n_sonic)
    w = 0.3 * rng.normal(size=n_sonic)
    tc = 24.0 + 0.2 * rng.normal(size=n_sonic)
    sonic_c, sonic_o = [], []
    for k in range(n_sonic):
        vals = [round(float(x), 3) for x in (u[k], v[k], w[k], tc[k])]
        if k == 400:  # a missing sample
            sonic_c.append(f"{t_sonic[k]},NAN,NAN,NAN,NAN")
            sonic_o.append(f"{t_sonic[k] // 1000}.{t_sonic[k] % 1000:03d};NAN;NAN;NAN;NAN")
            continue
        sonic_c.append(f"{t_sonic[k]},{vals[0]},{vals[1]},{vals[2]},{vals[3]}")
        # own sensor: x = contract v, y = contract u, z = -contract w, in cm/s; temperature in K
        own = [round(vals[1] * 100, 1), round(vals[0] * 100, 1), round(-vals[2] * 100, 1), round(vals[3] + 273.15, 3)]
        sonic_o.append(f"{t_sonic[k] // 1000}.{t_sonic[k] % 1000:03d};{own[3]};{own[0]};{own[1]};{own[2]}")
        if k == 200:  # the logger wrote this row twice
            sonic_c.append(sonic_c[-1])
            sonic_o.append(sonic_o[-1])
        if k == 600:  # a line cut short
            sonic_c.append(f"{t_sonic[k] + 15_000},1.2")
            sonic_o.append(f"{(t_sonic[k] + 15_000) // 1000}.{(t_sonic[k] + 15_000) % 1000:03d};297.1")
    (HERE / "contract").mkdir(exist_ok=True)
    (HERE / "own").mkdir(exist_ok=True)
    (HERE / "contract" / "sonic.csv").write_text("rpi_time_us,u_ms,v_ms,w_ms,t_sonic_c\n" + "\n".join(sonic_c) + "\n")
    (HERE / "contract" / "ins.csv").write_text(
        "rpi_time_us,utc,time_valid,ekf_valid,lat_deg,lon_deg,alt_m,vel_n_ms,vel_e_ms,vel_d_ms,roll_deg,pitch_deg,"
        "yaw_deg\n" + "\n".join(ins_rows_c) + "\n")
    (HERE / "own" / "sonic_log.txt").write_text(
        "# payload sonic, logger 2\nclock;Ts;X;Y;Z\nms;K;cm/s;cm/s;cm/s\n" + "\n".join(sonic_o) + "\n")
    with gzip.open(HERE / "own" / "ins_log.tsv.gz", "wt", compresslevel=9) as fh:
        fh.write("\t".join(["clock_ms", "gps_utc_s", "fix", "ekf_status", "lat_rad", "lon_rad", "height_m", "v_east",
                            "v_north", "v_up", "roll_rad", "pitch_rad", "heading_rad"]) + "\n")
        fh.write("\n".join(ins_rows_o) + "\n")


if __name__ == "__main__":
    main()
