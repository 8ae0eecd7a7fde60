r"""Figure captions written from the stored results they describe.

A caption says what is plotted and what this campaign shows: which flights, at which
heights, which were left out and why (the stored status flags), the ranges of the stored
numbers, and for the diagnosis figures the verdict of ``diagnosis.json``. Captions read the
same stored products as the figures (L4 files, ``campaign.json``, the diagnosis and
quadrotor JSON and CSV tables) and compute nothing beyond minima, maxima and counts of
stored numbers. Papers are cited by authors and year (:data:`dronewind.figures.style.PAPERS`).

Text is plain (reStructuredText-safe): units as "m s⁻¹", the same SI notation with negative
exponents that the figures write as ``m s$^{-1}$``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from dronewind.core.products import L4Products, drone_usable, load_l4_products, stored_scalar
from dronewind.core.qc import STATUS_FLAG_MEANINGS
from dronewind.core.verdict import verdict_sentence
from dronewind.figures.labels import HEIGHT_MARKERS, PAPERS, PathLike
from dronewind.tables import default_detail_flights

__all__ = ["campaign_captions", "diagnosis_captions", "flight_list", "published_caption", "quadrotor_captions",
           "verdict_sentence"]

MS = "m s⁻¹"
_MARKER_NAMES = {"o": "circles", "^": "triangles", "s": "squares", "D": "diamonds", "v": "inverted triangles",
                 "P": "crosses"}
P000, P001, P002 = PAPERS["000"], PAPERS["001"], PAPERS["002"]


def _runs(names: Sequence[str]) -> list[str]:
    """Collapse runs of three or more consecutive ids (``s01 s02 s03`` -> ``s01-s03``)."""
    import re

    out: list[str] = []
    run: list[tuple[str, int, str]] = []

    def flush() -> None:
        if len(run) >= 3:
            out.append(f"{run[0][2]}-{run[-1][2]}")
        else:
            out.extend(r[2] for r in run)
        run.clear()

    for name in names:
        m = re.fullmatch(r"([A-Za-z_]*)(\d+)", name)
        if m and run and m.group(1) == run[-1][0] and int(m.group(2)) == run[-1][1] + 1 \
                and len(m.group(2)) == len(run[-1][2]) - len(run[-1][0]):
            run.append((m.group(1), int(m.group(2)), name))
            continue
        flush()
        if m:
            run.append((m.group(1), int(m.group(2)), name))
        else:
            out.append(name)
    flush()
    return out


def flight_list(flights: Sequence[str]) -> str:
    """``"s01"``, ``"s01 and s02"``, ``"s01, s03 and s05"``; runs of ids collapse (``"s01-s10"``).

    ("no flight" when empty).
    """
    flights = _runs(list(flights))
    if not flights:
        return "no flight"
    return flights[0] if len(flights) == 1 else ", ".join(flights[:-1]) + " and " + flights[-1]


def _status(ds: Any, name: str) -> str:
    """The flag meaning of ``status_<name>`` (empty when absent or ok)."""
    var = f"status_{name}"
    if ds is None or var not in ds.variables:
        return ""
    flag = int(np.asarray(ds[var].values).reshape(-1)[0])
    return STATUS_FLAG_MEANINGS[flag] if 0 < flag < len(STATUS_FLAG_MEANINGS) else ""


class _Facts:
    """What the captions say about the payload flights, read from the L4 products."""

    def __init__(self, l4: L4Products) -> None:
        self.l4 = l4
        self.flights = sorted(l4)
        self.usable = [f for f in self.flights if drone_usable(l4[f])[0]]
        self.unusable = {f: drone_usable(l4[f])[1] or "no reason stored" for f in self.flights
                         if f not in self.usable}
        self.heights: dict[float, list[str]] = {}
        for f in self.flights:
            h = stored_scalar(l4[f].get("mast"), "height_m")
            if np.isfinite(h):
                self.heights.setdefault(h, []).append(f)

    def speeds(self, flights: Iterable[str]) -> list[float]:
        """Stored mast mean speeds of ``flights`` [m s-1] (finite only)."""
        return [s for f in flights if np.isfinite(s := stored_scalar(self.l4[f].get("mast"), "U_ms"))]

    def speed_range(self, flights: Iterable[str]) -> str:
        s = self.speeds(flights)
        if not s:
            return ""
        return f"{min(s):.1f} {MS}" if math.isclose(min(s), max(s), abs_tol=0.05) else \
            f"{min(s):.1f} to {max(s):.1f} {MS}"

    def markers(self) -> str:
        """Which marker stands for which reference height, with its flights."""
        parts = []
        for i, (h, flights) in enumerate(sorted(self.heights.items())):
            name = _MARKER_NAMES.get(HEIGHT_MARKERS[i % len(HEIGHT_MARKERS)], "markers")
            parts.append(f"{name}: reference sonic at {h:g} m ({flight_list(flights)})")
        if len(parts) == 1:
            parts[0] += "; every flight was compared at this one height"
        return "; ".join(parts)

    def left_out(self, names: Sequence[str]) -> str:
        """Sentence naming the usable flights whose stored quantities ``names`` are NaN, with the status."""
        missing = []
        for f in self.usable:
            reasons = set()
            for name in names:
                for sensor in ("drone", "mast"):
                    ds = self.l4[f].get(sensor)
                    if not np.isfinite(stored_scalar(ds, name)):
                        reasons.add(_status(ds, _STATUS.get(name, name)) or "not stored")
            if reasons:
                missing.append(f"{f} ({', '.join(sorted(reasons))})")
        return f" Not drawn: {flight_list(missing)}." if missing else ""

    def unusable_sentence(self) -> str:
        if not self.unusable:
            return ""
        items = [f"{f} ({reason})" for f, reason in self.unusable.items()]
        return f" Drone records flagged unusable and left out: {flight_list(items)}."

    def detail(self) -> list[str]:
        return [f for f in default_detail_flights(self.flights) if f in self.l4]

    def describe(self, flights: Iterable[str]) -> str:
        """``s01 (mast30 at 30 m, ū 3.0 m s⁻¹)`` for each flight."""
        out = []
        for f in flights:
            m = self.l4[f].get("mast")
            h, u = stored_scalar(m, "height_m"), stored_scalar(m, "U_ms")
            out.append(f"{f} ({h:g} m, mast ū {u:.1f} {MS})" if np.isfinite(h) and np.isfinite(u) else f)
        return flight_list(out)


#: Status variable that explains a NaN in a quantity (default: the quantity's own status).
_STATUS = {"U_ms": "statistics", "sigma_u_ms": "statistics", "sigma_v_ms": "statistics", "sigma_w_ms": "statistics",
           "uw_m2s2": "statistics", "vw_m2s2": "statistics", "wT_Kms": "temperature", "L_m": "obukhov",
           "L_u_m": "L_u", "L_v_m": "L_v", "L_w_m": "L_w"}


def _campaign_site(results: Path) -> tuple[float | None, dict[str, Any]]:
    """Site altitude [m] and the mast sonics of ``campaign.json`` (None and {} without it)."""
    path = results / "campaign.json"
    if not path.exists():
        return None, {}
    record = json.loads(path.read_text("utf-8"))
    content = record.get("manifest_content", record)
    sonics = {s["id"]: s for mast in content.get("masts") or [] for s in mast.get("sonics") or []}
    return float(content["site"]["altitude_m"]), sonics


def _lags(facts: _Facts) -> str:
    lags = [float(facts.l4[f]["drone"].attrs["lag_sonic_ins_s"]) for f in facts.usable
            if "drone" in facts.l4[f] and "lag_sonic_ins_s" in facts.l4[f]["drone"].attrs]
    if not lags:
        return ""
    return (f" The stored sonic-INS lags of the usable flights range from {min(lags):+.3f} s to {max(lags):+.3f} s "
            "(dashed and dash-dot lines).")


def campaign_captions(results_dir: PathLike) -> dict[str, str]:
    """Captions of the campaign figures (:func:`dronewind.figures.campaign.draw_all`) for this campaign.

    Parameters
    ----------
    results_dir : str or Path
        ``results/<campaign>/`` (``netcdf/L4``, ``campaign.json``).

    Returns
    -------
    dict of str to str
        Figure name -> caption.
    """
    results = Path(results_dir)
    facts = _Facts(load_l4_products(sorted((results / "netcdf" / "L4").glob("*_*.nc"))))
    altitude_m, sonics = _campaign_site(results)
    n, all_flights = len(facts.flights), flight_list(facts.flights)
    detail = facts.detail()
    rest = [f for f in facts.flights if f not in detail]
    speeds = facts.speed_range(facts.usable)
    sonic_text = flight_list([f"{sid} at {float(s['height_m']):g} m (head towards {float(s['azimuth_deg']):g}°)"
                              for sid, s in sonics.items() if "azimuth_deg" in s])
    unusable = facts.unusable_sentence()
    return {
        "fig04_tke_lag": f"Turbulent kinetic energy of the motion-corrected payload wind against the lag added to the "
        f"sonic clock relative to the INS, one curve per flight normalised by its minimum (dots), for the {n} "
        f"flights {all_flights}.{_lags(facts)} Unusable flights are drawn grey, dashed, and do not count for "
        f"the lag window. After {P000}, Fig. 4.",
        "fig07_positions": f"Left: payload height above ground (GNSS altitude minus the site altitude"
        f"{f' of {altitude_m:g} m' if altitude_m is not None else ''}) during the hover windows of {all_flights}, "
        f"with the mast sonic heights dotted. Right: payload track east and north of the mast, the sonic heads "
        f"({sonic_text or 'no azimuth recorded'}) as black lines, and arrows from each flight's median position "
        f"pointing where the wind measured by its reference sonic blows to (mast mean speeds {speeds or 'not stored'}"
        f"; the legend gives each flight's median height, speed and direction). After {P000}, Fig. 7.",
        "fig08_timeseries": f"Streamwise (u), cross-wind (v) and vertical (w) velocity in streamline coordinates "
        f"(L3, 8 Hz), drone (blue) and reference mast sonic (orange), for {facts.describe(detail)}. After {P000}, "
        f"Fig. 8.",
        "fig09_velocity_spectra": f"Frequency-weighted spectra f S_u, f S_v, f S_w (log-log) and co-spectrum "
        f"f Re(S_uw) (linear y) of drone (blue) and mast (orange) for {facts.describe(detail)}, with the "
        f"blunt/pointed model fitted to the drone (black; {P000}, Eqs 4-7); standard deviations and u'w' in the "
        f"panel titles. After {P000}, Fig. 9.",
        "fig10_temperature_series": f"Sonic temperature fluctuations (minus the stored mean of each sensor), drone "
        f"(blue) and mast (orange), for {facts.describe(detail)}; the means are in the legend. After {P000}, "
        f"Fig. 10.",
        "fig11_temperature_spectra": f"Frequency-weighted sonic-temperature spectrum f S_θ (log-log) and co-spectra "
        f"f Re(S_wθ) and f Re(S_uθ) (linear y), drone (blue) and mast (orange), for {facts.describe(detail)}. "
        f"After {P000}, Fig. 11.",
        "fig12_mean_and_sigma": f"Drone against mast: mean wind speed ū and standard deviations σ_u, σ_v, σ_w of "
        f"{flight_list(facts.usable)} (mast ū {speeds or 'not stored'}), one colour per flight; {facts.markers()}; "
        f"dashed: 1:1.{facts.left_out(['U_ms', 'sigma_u_ms', 'sigma_v_ms', 'sigma_w_ms'])}{unusable} "
        f"After {P000}, Fig. 12.",
        "fig13_fluxes_obukhov": f"Drone against mast covariances u'w', v'w', w'θ_v' and Obukhov length L "
        f"(symmetric-log axes, linear around zero) of {flight_list(facts.usable)}; {facts.markers()}."
        f"{facts.left_out(['uw_m2s2', 'vw_m2s2', 'wT_Kms', 'L_m'])}{unusable} After {P000}, Fig. 13.",
        "fig14_length_scales": f"Drone against mast integral length scales L_u, L_v, L_w (exponential fit of the "
        f"autocovariance and Taylor's hypothesis); {facts.markers()}. Scales are not stored where I_u ≥ 0.5 or "
        f"ū ≤ 1 {MS}.{facts.left_out(['L_u_m', 'L_v_m', 'L_w_m'])}{unusable} After {P000}, Fig. 14.",
        "fig15_quadrant": f"Quadrant analysis of the frequency-averaged spectral ratios ⟨S_w/S_u⟩ (left) and "
        f"⟨S_v/S_u⟩ (right) over 2 < f z/ū < 10, drone against mast, coloured by the mast mean speed, for "
        f"{flight_list(facts.usable)}; lines at the isotropic 4/3.{facts.left_out(['Sw_Su', 'Sv_Su'])}{unusable} "
        f"After {P000}, Figs 6 and 15.",
        "fig16_uncertainty": f"Normalised random-uncertainty metrics ({P000}, Eqs 10-13) of the variances, momentum "
        f"fluxes and buoyancy flux, drone (y) against mast (x), for {flight_list(facts.usable)}; {facts.markers()}; "
        f"green: below 0.5, low statistical uncertainty.{unusable} After {P000}, Fig. 16.",
        "figB1_normalised_velocity_spectra": "Spectra of u, v, w normalised by their variances, and the u-w "
        "co-spectrum normalised by u'w', drone (blue) and mast (orange), for "
        f"{facts.describe(rest) if rest else 'no further flight (all are shown in Fig. 9)'}. After {P000}, Fig. B1.",
        "figB2_normalised_temperature_spectra": "Sonic-temperature spectrum normalised by its variance and the w-θ "
        "and u-θ co-spectra normalised by their covariances, drone (blue) and mast (orange), for "
        f"{facts.describe(rest) if rest else 'no further flight (all are shown in Fig. 11)'}. After {P000}, Fig. B2.",
    }


# ----------------------------------------------------------------------------- diagnosis


def diagnosis_captions(diagnosis_json: PathLike, n_spectra_flights: int = 3) -> dict[str, str]:
    """Captions of ``diagnosis_residuals`` and ``diagnosis_spectra`` from ``diagnosis.json``.

    Parameters
    ----------
    diagnosis_json : str or Path
        The campaign diagnosis.
    n_spectra_flights : int
        Flights shown in the spectra figure (:func:`dronewind.figures.diagnosis.spectra_figure`).

    Returns
    -------
    dict of str to str
    """
    from dronewind.figures.diagnosis import spread_by_speed

    diag = json.loads(Path(diagnosis_json).read_text("utf-8"))
    flights = list(diag.get("flights") or [])
    speed = {r["flight"]: r["U_ms"] for r in diag.get("baseline", {}).get("residuals") or [] if "U_ms" in r}
    shown = spread_by_speed([f for f in flights if f in speed], speed, n_spectra_flights) if speed else []
    metrics = diag.get("baseline", {}).get("metrics", {})
    chi2 = (f" Baseline misfit χ² = {metrics['chi2']:.1f} over {metrics.get('n_features_used', '?')} features."
            if "chi2" in metrics else "")
    named = list(diag.get("named_causes") or [])
    after = (f"and with the named cause(s) {', '.join(named)} at their fitted values, rerun with new seeds (blue)"
             if named else "(nothing was named, so the extended model is the baseline)")
    verdict = verdict_sentence(diag)
    return {
        "diagnosis_residuals": f"Drone-minus-mast residual features (measured minus predicted) of the {len(flights)} "
        f"flights {flight_list(flights)} against the mast mean wind speed, for the forward model without any "
        f"mechanism (baseline, red) {after}. Error bars: sampling errors ({P000}, Eqs 10-13, scaled by the "
        f"spread of the forward model's seeds).{chi2} {verdict}",
        "diagnosis_spectra": "Premultiplied spectra f S_u and f S_w of the drone (black) and the mast (grey) for "
        f"{flight_list([f'{f} (mast ū {speed[f]:.1f} {MS})' for f in shown]) if shown else 'no flight'}, spanning "
        "the campaign's wind speeds, against the forward model of each flight without any mechanism (red, "
        "dashed) and with the named mechanism(s) at their fitted values (blue; the same seed, so the difference "
        f"is the mechanisms' effect); when nothing is named one model curve is drawn. {verdict}",
    }


def published_caption(before_after_json: PathLike, diagnosis_json: PathLike) -> str:
    """Caption of ``published_before_after`` from the stored before/after summary and its diagnosis."""
    summary = json.loads(Path(before_after_json).read_text("utf-8"))
    diag = json.loads(Path(diagnosis_json).read_text("utf-8"))
    flights = sorted(summary.get("claims", {}).get("baseline", {}).get("per_flight", {}))
    return (f"The published numbers of {P000} (Tables 4-5, Sects 5.2 and 6) against the forward model at the Table 4 "
            f"conditions of the stationary samples {flight_list(flights)}, before (baseline, no mechanism, grey) and "
            "after (the named mechanism(s) at their fitted values, red). Left: excess of the drone's σ_w over the "
            "mast's against wind speed, with the two Table 5 samples (stars). Right: frequency-averaged ⟨S_w/S_u⟩ "
            f"(2 < f z/ū < 10) of drone against mast with the published extremes. {verdict_sentence(diag)}")


# ----------------------------------------------------------------------------- quadrotor and tunnel


def _csv(path: Path) -> pd.DataFrame | None:
    return pd.read_csv(path) if path.exists() and path.stat().st_size > 0 else None


def _speed_range(lower_ms: float, upper_ms: float) -> str:
    """``"below 4 m s⁻¹"``, ``"4 to 12 m s⁻¹"``, ``"above 12 m s⁻¹"`` or ``"all speeds"``."""
    if np.isinf(lower_ms) and np.isinf(upper_ms):
        return "all speeds"
    if np.isinf(lower_ms):
        return f"below {upper_ms:g} {MS}"
    if np.isinf(upper_ms):
        return f"above {lower_ms:g} {MS}"
    return f"{lower_ms:g} to {upper_ms:g} {MS}"


def quadrotor_captions(tables_dir: PathLike) -> dict[str, str]:
    """Captions of the quadrotor (SWUF-3D) and wind-tunnel figures from the stored tables.

    Parameters
    ----------
    tables_dir : str or Path
        ``results/<campaign>/tables``.

    Returns
    -------
    dict of str to str
        Figure name -> caption, for the figures whose tables exist.
    """
    tables = Path(tables_dir)
    out: dict[str, str] = {}
    cal, win = _csv(tables / "quadrotor_calibration.csv"), _csv(tables / "quadrotor_windows.csv")
    if cal is not None and win is not None:
        n_uav, n_flight = len(cal), win["flight"].nunique()
        val = win[win["validation"].astype(bool)] if "validation" in win else win.iloc[0:0]
        rmse = f"{cal['rmse_ms'].min():.2f} to {cal['rmse_ms'].max():.2f} {MS}"
        heights = sorted({float(h) for h in win["ref_height_m"].dropna().to_numpy(dtype=float)})
        hs = flight_list([f"{h:g}" for h in heights]) + " m" if heights else "no height"
        out.update({
            "quadrotor_fig3_individual": f"10-min wind speed of {n_uav} UAVs against the tower over {n_flight} flights "
            f"({len(win)} windows at {hs}), individual calibration per UAV. After {P001}, Fig. 3.",
            "quadrotor_fig4_regression": f"Offset-corrected tilt against the tower wind speed of the {len(win)} "
            f"windows and the universal regression law (Eq. 18 form). After {P001}, Fig. 4.",
            "quadrotor_fig5_validation": f"Validation windows ({len(val)} windows of {val['flight'].nunique()} "
            "flights) not used in the calibration: UAV against tower wind speed with the universal law and the "
            f"calibrated pitch offsets; calibration RMSE per UAV {rmse}. After {P001}, Fig. 5.",
            "quadrotor_fig6_direction": f"Wind direction of the UAVs (yaw corrected by the calibrated offsets, "
            f"{cal['yaw_offset_deg'].min():.1f}° to {cal['yaw_offset_deg'].max():.1f}°) against the tower. "
            f"After {P001}, Fig. 6.",
            "quadrotor_fig7_timeseries": f"1 Hz UAV wind speed and the tower's 1-min means of the flight with most "
            f"UAVs. After {P001}, Fig. 7.",
            "quadrotor_fig8_profiles": f"Wind-speed profiles at {hs}: UAVs (error bars: calibration RMSE) against "
            f"the tower. After {P001}, Fig. 8.",
            "quadrotor_fig9_variance": f"Variance of the 1-min mean speeds in each window, UAV against tower (the "
            f"tower reports 1-min means; analogue of {P001}, Fig. 9).",
        })
    tun = _csv(tables / "tunnel_calibration.csv")
    if tun is not None:
        ranges = flight_list([f"{axis} {_speed_range(lo, hi)}" for axis, lo, hi in zip(
            tun["axis"], tun["lower_ms"].to_numpy(dtype=float), tun["upper_ms"].to_numpy(dtype=float), strict=True)])
        out.update({
            "tunnel_fig4_sideslip": f"RMSE of the UAS speed against the CTA speed per angle of sideslip (wind-tunnel "
            f"calibration per speed range: {ranges}). After {P002}, Fig. 4.",
            "tunnel_fig5_portability": f"Speed error of each UAS against the CTA speed: portability of one "
            f"calibration to the fleet. After {P002}, Fig. 5.",
            "tunnel_fig6_gusts": f"RMSE of the UAS speed in IEC gusts at the base speed V0 and at the peak Vp, per "
            f"preset. After {P002}, Fig. 6.",
            "tunnel_fig7_steps": f"RMSE of the UAS speed in velocity steps, per preset. After {P002}, Fig. 7.",
            "tunnel_fig9_variance": f"Turbulence variance, UAS against CTA at the CTA's full bandwidth and cut at "
            f"the UAS's highest resolved frequency. After {P002}, Fig. 9.",
        })
    return out


def block_captions(tables_dir: PathLike) -> dict[str, str]:
    """Caption of the block-series figure of a tower- or mast-only campaign from ``block_stats.csv``.

    Parameters
    ----------
    tables_dir : str or Path
        ``results/<campaign>/tables``.

    Returns
    -------
    dict of str to str
        ``{"block_series": caption}`` when the table exists, else empty.
    """
    table = _csv(Path(tables_dir) / "block_stats.csv")
    if table is None:
        return {}
    usable = table["usable"].astype(str).str.lower().isin(("true", "1"))
    heights = table.groupby(["record", "sensor"], sort=True)["height_m"].first()
    sonics = [f"{key[0]} {key[1]} ({float(h):g} m)" for key, h in zip(heights.index, heights.to_numpy(), strict=True)]
    span = f"{table['start_utc'].min()} to {table['end_utc'].max()}" if len(table) else "no block"
    lengths = (pd.to_datetime(table["end_utc"]) - pd.to_datetime(table["start_utc"])).dt.total_seconds()
    block = f"{lengths.iloc[0] / 60:g}-min" if len(table) else ""
    return {"block_series": (
        f"Block statistics of {flight_list(sonics)}, {block} blocks aligned to UTC, {span}: mean wind speed U, "
        f"wind-from direction, σ_w, friction velocity u*, kinematic heat flux w'T', stability z/L and the "
        f"inertial-subrange ratio S_w/S_u (tables/block_stats.csv; streamline coordinates per block, "
        f"the same statistics as of every sonic record). {int(usable.sum())} of "
        f"{len(table)} blocks usable; the others are listed under the axes with their reason.")}
