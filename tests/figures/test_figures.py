"""Tests for dronewind.figures: every figure draws from the stored products, deterministically."""

from __future__ import annotations

import logging
import logging.handlers
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import matplotlib.image as mpimg
import numpy as np
import pytest
from PIL import Image

from dronewind.diagnose.features import FEATURES
from dronewind.diagnose.report import FEATURE_LABELS
from dronewind.errors import InputError
from dronewind.figures import (
    campaign,
    diagnosis,
    fluxes,
    quadrant,
    spectra,
    statistics,
    synchronisation,
    timeseries,
)
from dronewind.figures.labels import APPENDIX_FIGURES
from dronewind.figures.style import DPI
from tests.products_fixture import set_nan, write_products


@pytest.fixture(scope="module")
def products(tmp_path_factory) -> Path:
    return write_products(tmp_path_factory.mktemp("products"))


@pytest.fixture(scope="module")
def drawn_figures(products: Path, tmp_path_factory) -> tuple[Path, dict, list[str]]:
    """Every campaign figure of the products fixture (several flights, 30 and 60 m), drawn once.

    Returns the folder of the files, the figure objects every ``save_figure`` received (for
    the layout tests; the real save still runs, :class:`_Spy`) and the INFO messages of the
    ``dronewind`` logger while drawing.
    """
    from dronewind.figures import positions, quadrant, scatter, style

    spy = _Spy()
    mp = pytest.MonkeyPatch()
    for module in (campaign, diagnosis, fluxes, positions, quadrant, scatter, spectra, statistics, synchronisation,
                   timeseries):
        if hasattr(module, "save_figure"):
            mp.setattr(module, "save_figure", spy.wrap(style.save_figure))
    handler = logging.handlers.BufferingHandler(capacity=1_000_000)  # keeps every record (never fills)
    logger = logging.getLogger("dronewind")
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        out = tmp_path_factory.mktemp("figures")
        campaign.draw_all(products, out)
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
        mp.undo()
    return out, spy.figures, [record.getMessage() for record in handler.buffer]


@pytest.fixture(scope="module")
def drawn(drawn_figures: tuple[Path, dict, list[str]]) -> Path:
    return drawn_figures[0]


def test_campaign_figures_log_each_figure(drawn_figures: tuple[Path, dict, list[str]]) -> None:
    """The campaign figures job (about 60 CPU-s on the default campaign) logs every figure it draws."""
    names = list(campaign.figure_captions())
    lines = [m for m in drawn_figures[2] if m.startswith("figure ")]
    for k, name in enumerate(names, start=1):
        assert any(re.fullmatch(rf"figure {k}/{len(names)} {name} drawn in \d+\.\d s", line) for line in lines), \
            (name, lines)


def test_named_figures_alone_are_those_of_the_whole_set(products: Path, drawn: Path, tmp_path: Path) -> None:
    """The workflow's two figure jobs draw subsets (``names``): the Appendix B figures drawn alone
    are byte for byte those of the whole set, and no other file is written; an unknown name
    stops with the valid ones listed."""
    written = campaign.draw_all(products, tmp_path, names=APPENDIX_FIGURES)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in written)
    assert {p.stem for p in written} == set(APPENDIX_FIGURES)
    for path in written:
        assert path.read_bytes() == (drawn / path.name).read_bytes(), path.name
    with pytest.raises(ValueError, match="fig99_none.*expected names of"):
        campaign.draw_all(products, tmp_path, names=["fig99_none"])


def _files(root: Path, level: str, pattern: str = "*.nc") -> list[Path]:
    return sorted((root / "netcdf" / level).glob(pattern))


def _description(png: Path) -> str:
    with Image.open(png) as im:
        return im.text.get("Description", "")


def test_captions_match_functions() -> None:
    captions = campaign.figure_captions()
    assert set(captions) == set(campaign.FIGURE_FUNCTIONS)
    assert all(len(text) > 60 for text in captions.values())


def test_every_figure_written_and_readable(drawn: Path) -> None:
    for name in campaign.figure_captions():
        png, pdf = drawn / f"{name}.png", drawn / f"{name}.pdf"
        assert png.stat().st_size > 10_000, name
        assert pdf.read_bytes()[:5] == b"%PDF-", name
        image = mpimg.imread(png)
        assert image.ndim == 3 and image.shape[2] == 4, name
        assert image.shape[0] >= 300 and image.shape[1] >= 500, name
        assert image[..., :3].std() > 0.05, name  # not a blank page
        assert b"CreationDate" not in pdf.read_bytes(), name
        with Image.open(png) as im:
            assert "Software" not in im.text and "date" not in " ".join(im.text).lower(), name


def test_png_size_is_figsize_times_dpi(drawn: Path) -> None:
    # fixed sizes (no tight bounding box): fig04 is 8 x 4.6 in (legend outside), fig15 10.5 x 4.8 in
    assert mpimg.imread(drawn / "fig04_tke_lag.png").shape[:2] == (round(4.6 * DPI), round(8.0 * DPI))
    assert mpimg.imread(drawn / "fig15_quadrant.png").shape[:2] == (round(4.8 * DPI),
                                                                    round(10.5 * DPI))
    # Fig. 9: 4 panels per detailed flight (2 flights): 13 x (3.1 * 2 + 0.3) in
    assert mpimg.imread(drawn / "fig09_velocity_spectra.png").shape[:2] == (round(6.5 * DPI),
                                                                            round(13 * DPI))


def test_skipped_items_are_named_with_reasons(drawn: Path) -> None:
    # s04 is flagged unusable in the fixture; s02 (0.8 m/s) has NaN ratios and length scales by status
    for name in ("fig04_tke_lag", "fig07_positions", "fig12_mean_and_sigma", "fig16_uncertainty"):
        assert "s04: drone record unusable" in _description(drawn / f"{name}.png"), name
    assert "low_wind_speed" in _description(drawn / "fig15_quadrant.png")
    assert "taylor_hypothesis_invalid" in _description(drawn / "fig14_length_scales.png")
    assert _description(drawn / "figB2_normalised_temperature_spectra.png").startswith("skipped")


def test_deterministic_bytes(products: Path, drawn: Path, tmp_path: Path) -> None:
    l4 = _files(products, "L4")
    a = spectra.fig09_velocity_spectra(l4, tmp_path / "fig09_velocity_spectra")
    b = synchronisation.fig04_tke_lag(_files(products, "L2", "*_drone.nc"), tmp_path / "fig04_tke_lag")
    c = timeseries.fig10_temperature_series(_files(products, "L3"), l4, tmp_path / "fig10_temperature_series")
    for path in a + b + c:  # PNG and PDF, including rasterised time series (fig10)
        assert path.read_bytes() == (drawn / path.name).read_bytes(), path.name


def test_nan_missing_and_unusable_inputs_do_not_crash(products: Path, drawn: Path, tmp_path: Path) -> None:
    l4_dir = tmp_path / "L4"
    shutil.copytree(products / "netcdf" / "L4", l4_dir)
    set_nan(l4_dir / "s01_drone.nc", "sigma_w_ms")
    set_nan(l4_dir / "s03_drone.nc", "S_u")
    set_nan(l4_dir / "s03_drone.nc", "Sw_Su")
    set_nan(l4_dir / "s01_drone.nc", "S_w_model")
    (l4_dir / "s03_mast.nc").unlink()
    l4 = sorted(l4_dir.glob("*.nc"))
    out = tmp_path / "out"
    f12 = statistics.fig12_mean_and_sigma(l4, out / "fig12")
    assert "s01: sigma_w_ms not drawn (drone NaN while status_statistics = ok)" in _description(f12[0])
    assert "s03: U_ms not drawn (mast no product)" in _description(f12[0])
    assert f12[0].read_bytes() != (drawn / "fig12_mean_and_sigma.png").read_bytes()
    f9 = spectra.fig09_velocity_spectra(l4, out / "fig09", flights=["s01", "s03"])
    text = _description(f9[0])
    assert "s03 drone: S_u not available" in text and "s01: no fitted model for w" in text
    f15 = quadrant.fig15_quadrant(l4, out / "fig15")
    assert "s03: Sw_Su not drawn" in _description(f15[0])
    spectra.figB1_normalised_velocity_spectra(l4, out / "figB1")
    timeseries.fig08_timeseries(_files(products, "L3"), l4, out / "fig08", flights=["s04", "s99"])
    assert "s99: no L3 file" in _description(out / "fig08.png")
    assert "s04: drone record unusable" in _description(out / "fig08.png")
    # no input at all: an annotated empty figure, no exception
    for func in (statistics.fig12_mean_and_sigma, quadrant.fig15_quadrant, spectra.fig09_velocity_spectra):
        paths = func([], out / f"empty_{func.__name__}")
        assert all(p.stat().st_size > 0 for p in paths)
    synchronisation.fig04_tke_lag([], out / "empty_fig04")


def test_fig16_rejects_unknown_metric(products: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError):
        fluxes.fig16_uncertainty(_files(products, "L4"), tmp_path / "fig16", metric="b")


def _evidence(n_flights: int) -> SimpleNamespace:
    rng = np.random.default_rng(3)
    shape = (n_flights, len(FEATURES))
    return SimpleNamespace(flights=[f"s{i:02d}" for i in range(1, n_flights + 1)], y=rng.normal(size=shape),
                           baseline=rng.normal(size=shape), sigma=np.abs(rng.normal(size=shape)) + 0.1,
                           conditions=[{"mean_speed_ms": 2.0 + 2.0 * i} for i in range(n_flights)])


def _binned(scale: float) -> dict:
    f = np.logspace(-2, 0.5, 20)
    return {"f_hz": f.tolist(), **{f"{s}_{c}": (scale / (1 + f / 0.1) ** (5 / 3)).tolist()
                                   for s in ("drone", "mast") for c in ("u", "w")}}


def test_diagnosis_figures_from_evidence(tmp_path: Path) -> None:
    ev = _evidence(4)
    diag = {"campaign": "demo", "named_causes": ["w_gain"]}
    after = ev.baseline + 0.1
    res = diagnosis.residuals_figure(ev, after, diag, tmp_path, features=FEATURES, labels=FEATURE_LABELS)
    measured = {f: _binned(1.0) for f in ev.flights}
    model = {f: {"baseline": _binned(0.9), "extended": _binned(1.1)} for f in ev.flights}
    spec = diagnosis.spectra_figure(ev, measured, model, diag, tmp_path)
    assert [p.name for p in res + spec] == ["diagnosis_residuals.png", "diagnosis_residuals.pdf",
                                            "diagnosis_spectra.png", "diagnosis_spectra.pdf"]
    assert mpimg.imread(spec[0]).shape[:2] == (round(3 * 3.4 * DPI), round(11 * DPI))  # 3 of 4 flights shown
    assert _description(spec[0]) == "skipped: none"
    # no usable flight: annotated figures, no exception
    empty = _evidence(0)
    res = diagnosis.residuals_figure(empty, None, diag, tmp_path / "empty", features=FEATURES, labels=FEATURE_LABELS)
    spec = diagnosis.spectra_figure(empty, {}, {}, diag, tmp_path / "empty")
    assert _description(res[0]) == "skipped: no usable flight"
    assert _description(spec[0]) == "skipped: no flight with stored spectra"


# ----------------------------------------------------------------------------- layout: nothing hides data


class _Spy:
    """Records every figure the figure functions save (the real save still runs)."""

    def __init__(self) -> None:
        self.figures: dict[str, object] = {}

    def wrap(self, real):
        def save(fig, out_stem, notes=()):
            self.figures[Path(out_stem).name] = fig
            return real(fig, out_stem, notes)
        return save


def _fleet_tables(tmp: Path) -> Path:
    """Quadrotor and tunnel tables of a small synthetic fleet (the columns the figures read), in ``tmp``."""
    import json

    import pandas as pd

    rng = np.random.default_rng(3)
    n = 60
    ref = rng.uniform(1.0, 11.0, n)
    direction = rng.uniform(20.0, 340.0, n)
    win = pd.DataFrame({
        "uav": [f"q{k % 6 + 1:02d}" for k in range(n)], "flight": [f"f{k % 8 + 1:02d}" for k in range(n)],
        "ref_speed_ms": ref, "speed_individual_ms": ref + rng.normal(0, 0.2, n),
        "uav_speed_ms": ref + rng.normal(0, 0.3, n),
        "tilt_deg": 2.0 + 1.5 * ref + rng.normal(0, 0.5, n), "validation": [k % 3 == 0 for k in range(n)],
        "ref_from_deg": direction, "uav_from_deg": direction + rng.normal(0, 5, n),
        "var_ref_1min_m2s2": rng.uniform(0.05, 1.0, n), "var_uav_1min_m2s2": rng.uniform(0.05, 1.0, n)})
    win["validation"] = win["validation"].astype(int)
    heights = np.arange(10.0, 100.0, 10.0)
    prof = pd.concat([pd.DataFrame({"flight": f, "height_m": heights, "ref_height_m": heights,
                                    "uav_speed_ms": 4 + 0.03 * heights + rng.normal(0, 0.2, heights.size),
                                    "ref_speed_ms": 4 + 0.03 * heights, "rmse_ms": 0.2}) for f in ("f01", "f02")])
    tables = tmp / "tables"
    tables.mkdir(parents=True)
    win.to_csv(tables / "quadrotor_windows.csv", index=False)
    prof.to_csv(tables / "quadrotor_profiles.csv", index=False)
    pd.DataFrame({"flight": ["f03"], "uav": ["q02"], "reason": ["log cut short"]}).to_csv(
        tables / "quadrotor_problems.csv", index=False)
    (tmp / "calibration.json").write_text(json.dumps({
        "regression_curve": {"tilt_deg": [0.0, 10.0, 20.0], "speed_ms": [0.0, 6.0, 11.0]},
        "aero": {"cd0a0_m2": 0.0123, "cp_m2_per_rad": 0.0456}, "calibration_window_s": 600}))
    speeds = np.arange(2.0, 17.0, 2.0)
    pd.concat([pd.DataFrame({"aos_deg": a, "speed_bin_ms": speeds, "rmse_ms": rng.uniform(0.0, 0.2, speeds.size)})
               for a in (0.0, 30.0, 90.0)]).to_csv(tables / "tunnel_sideslip.csv", index=False)
    pd.concat([pd.DataFrame({"kind": "portability", "uas": u, "cta_ms": speeds,
                             "error_ms": rng.normal(0, 0.2, speeds.size)}) for u in ("u06", "u31")]).to_csv(
        tables / "tunnel_steps_accuracy.csv", index=False)
    pd.DataFrame({"v0_set_ms": [6.0, 8.0], "vg_set_ms": [4.0, 5.0], "rmse_v0_ms": [0.1, 0.2],
                  "rmse_vp_ms": [0.3, 0.4]}).to_csv(tables / "tunnel_gust_summary.csv", index=False)
    pd.DataFrame({"v0_set_ms": [5.0], "vdu_set_ms": [7.0], "rmse_v_high_ms": [0.2], "rmse_v_low_ms": [0.1],
                  "rmse_dv_up_ms": [0.3], "rmse_dv_down_ms": [0.25]}).to_csv(tables / "tunnel_step_summary.csv",
                                                                             index=False)
    pd.DataFrame({"var_cta_full": [1.2, 0.6, 2.0], "var_cta_cut_fmax": [1.0, 0.5, 1.7],
                  "var_uas": [0.95, 0.52, 1.65]}).to_csv(tables / "tunnel_turbulence.csv", index=False)
    return tables


@pytest.fixture(scope="module")
def fleet_figures(tmp_path_factory) -> dict:
    """The quadrotor (Wetz et al. 2021) and tunnel (Kistner et al. 2024) figures of a small synthetic fleet."""
    from dronewind.figures import quadrotor, style

    tmp = tmp_path_factory.mktemp("fleet")
    tables = _fleet_tables(tmp)
    spy = _Spy()
    mp = pytest.MonkeyPatch()
    mp.setattr(quadrotor, "save_figure", spy.wrap(style.save_figure))
    try:
        out = tmp / "figures"
        win = quadrotor.pd.read_csv(tables / "quadrotor_windows.csv", dtype={"uav": str, "flight": str})
        prof = quadrotor.pd.read_csv(tables / "quadrotor_profiles.csv", dtype={"flight": str})
        summary = __import__("json").loads((tmp / "calibration.json").read_text())
        quadrotor._fig3_individual(win, "600-s windows", out / "quadrotor_fig3_individual.png", "")
        quadrotor._fig4_regression(win, summary, out / "quadrotor_fig4_regression.png", "")
        quadrotor._fig5_validation(win, out / "quadrotor_fig5_validation.png", "")
        quadrotor._fig6_direction(win, out / "quadrotor_fig6_direction.png", "")
        quadrotor._fig8_profiles(prof, out / "quadrotor_fig8_profiles.png", "left out: 1 UAV log")
        quadrotor._fig9_variance(win, out / "quadrotor_fig9_variance.png")
        quadrotor.tunnel_figures(tables, [out / f"{name}.png" for name in quadrotor.TUNNEL_FIGURES])
    finally:
        mp.undo()
    for name in spy.figures:  # the vector copy beside every PNG
        assert (out / f"{name}.png").is_file() and (out / f"{name}.pdf").is_file(), name
    return spy.figures


def test_fleet_figures_standard(fleet_figures: dict, tmp_path: Path) -> None:
    """Vector copies, stated agreement at the precision that is real, each legend label once."""
    from dronewind.figures.quadrotor import agreement

    assert {"quadrotor_fig3_individual", "quadrotor_fig8_profiles", "tunnel_fig4_sideslip",
            "tunnel_fig9_variance"} <= set(fleet_figures)
    for name, fig in fleet_figures.items():
        for leg in [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None] + list(fig.legends):
            labels = [t.get_text() for t in leg.get_texts()]
            assert len(labels) == len(set(labels)), (name, labels)
    title = fleet_figures["quadrotor_fig3_individual"].axes[0].get_title()
    assert re.search(r"RMSE = 0\.[12]\d m", title) and "R² = 0.99" in title and "n = 60" in title
    assert "RMSE = 0.0030 m" in agreement([1.0, 2.0, 3.0], [1.003, 2.003, 3.003], "m")  # never "0.000"
    assert "R² = 1" not in agreement([1.0, 2.0, 3.0, 4.0], [1.0001, 2.0, 3.0, 4.0])


@pytest.fixture(scope="module")
def saved_figures(drawn_figures: tuple[Path, dict, list[str]], fleet_figures: dict, tmp_path_factory) -> dict:
    """Every figure: the campaign's (:func:`drawn_figures`), the diagnosis, quadrotor and tunnel figures."""
    from dronewind.figures import style

    spy = _Spy()
    mp = pytest.MonkeyPatch()
    mp.setattr(diagnosis, "save_figure", spy.wrap(style.save_figure))
    try:
        out = tmp_path_factory.mktemp("layout")
        ev = _evidence(4)
        diag = {"campaign": "demo", "named_causes": ["w_gain"]}
        diagnosis.residuals_figure(ev, ev.baseline + 0.1, diag, out, features=FEATURES, labels=FEATURE_LABELS)
        model = {f: {"baseline": _binned(0.9), "extended": _binned(0.9)} for f in ev.flights}
        diagnosis.spectra_figure(ev, {f: _binned(1.0) for f in ev.flights}, model, diag, out)
    finally:
        mp.undo()
    return {**drawn_figures[1], **spy.figures, **fleet_figures}


def _data_points(ax) -> np.ndarray:
    """Display coordinates of every drawn data point of the lines of ``ax`` inside its view."""
    pts = []
    (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    for line in ax.get_lines():
        x, y = (np.asarray(v, dtype=float) for v in line.get_data())
        if line.get_transform() != ax.transData or x.size == 0:
            continue  # axis-fraction lines (axhline/axvline) are frame, not data
        keep = np.isfinite(x) & np.isfinite(y) & (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        if keep.any():
            pts.append(ax.transData.transform(np.column_stack([x[keep], y[keep]])))
    return np.vstack(pts) if pts else np.empty((0, 2))


def _boxes_overlap(boxes) -> list[tuple[int, int]]:
    return [(i, j) for i in range(len(boxes)) for j in range(i + 1, len(boxes)) if boxes[i].overlaps(boxes[j])]


def test_no_legend_covers_data(saved_figures: dict) -> None:
    assert {"fig04_tke_lag", "fig07_positions", "fig13_fluxes_obukhov", "fig15_quadrant",
            "diagnosis_spectra"} <= set(saved_figures)
    for name, fig in saved_figures.items():
        renderer = fig.canvas.get_renderer()
        legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
        suptitle = fig._suptitle if fig._suptitle is not None and fig._suptitle.get_text() else None
        for leg in legends:
            box = leg.get_window_extent(renderer)
            if suptitle is not None:  # a figure legend above the panels and the figure's title both at the top
                assert not box.overlaps(suptitle.get_window_extent(renderer)), (name, suptitle.get_text())
            for ax in fig.axes:
                pts = _data_points(ax)
                inside = (pts[:, 0] > box.x0) & (pts[:, 0] < box.x1) & (pts[:, 1] > box.y0) & (pts[:, 1] < box.y1)
                assert not inside.any(), f"{name}: legend covers {int(inside.sum())} data points of an axes"
                titles = [t for t in (ax.title, ax._left_title, ax._right_title) if t.get_text()]
                for title in titles:
                    assert not box.overlaps(title.get_window_extent(renderer)), (name, title.get_text())


def test_point_labels_do_not_overlap(saved_figures: dict) -> None:
    from matplotlib.text import Text

    labelled = 0
    for name, fig in saved_figures.items():
        renderer = fig.canvas.get_renderer()
        for ax in fig.axes:
            texts = [t for t in ax.texts if t.get_visible() and t.get_text()]
            for t in texts:
                if hasattr(t, "update_positions"):
                    t.update_positions(renderer)
            boxes = [Text.get_window_extent(t, renderer) for t in texts]
            assert not _boxes_overlap(boxes), (name, [t.get_text() for t in texts])
            labelled += len(texts)
    assert labelled > 10


def test_no_marker_is_clipped(saved_figures: dict) -> None:
    checked = 0
    for name, fig in saved_figures.items():
        renderer = fig.canvas.get_renderer()
        for ax in fig.axes:
            (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
            frame = ax.get_window_extent(renderer)
            for line in ax.get_lines():
                if line.get_linestyle() not in ("None", "none", "") or line.get_marker() in (None, "None", ""):
                    continue
                x, y = (np.asarray(v, dtype=float) for v in line.get_data())
                ok = np.isfinite(x) & np.isfinite(y)
                if not ok.any():
                    continue
                assert np.all((x[ok] >= x0) & (x[ok] <= x1) & (y[ok] >= y0) & (y[ok] <= y1)), (name, x, y)
                # the whole marker, not only its centre, lies inside the axes
                half = 0.5 * line.get_markersize() * fig.dpi / 72.0
                px = ax.transData.transform(np.column_stack([x[ok], y[ok]]))
                assert np.all((px[:, 0] - frame.x0 >= half) & (frame.x1 - px[:, 0] >= half)
                              & (px[:, 1] - frame.y0 >= half) & (frame.y1 - px[:, 1] >= half)), (name, x, y)
                checked += int(ok.sum())
    assert checked > 50


def test_tick_labels_do_not_collide(saved_figures: dict) -> None:
    for name, fig in saved_figures.items():
        renderer = fig.canvas.get_renderer()
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                lo, hi = sorted(axis.get_view_interval())
                labels = [t.label1 for t in axis.get_major_ticks()
                          if lo <= t.get_loc() <= hi and t.label1.get_visible() and t.label1.get_text()]
                boxes = [lab.get_window_extent(renderer) for lab in labels]
                assert not _boxes_overlap(boxes), (name, [lab.get_text() for lab in labels])


def test_symlog_ticks_are_thinned_decades() -> None:
    from dronewind.figures.scatter import symlog_ticks

    ticks = symlog_ticks(5e4, 1.0)
    assert len(ticks) <= 5 and 0.0 in ticks and 1e4 in ticks and -1e4 in ticks
    assert symlog_ticks(50.0, 10.0) == [-10.0, 0.0, 10.0]


def test_captions_state_this_campaign(products: Path) -> None:
    from dronewind.figures.captions import campaign_captions

    captions = campaign_captions(products)
    assert set(captions) == set(campaign.figure_captions())
    fig12 = captions["fig12_mean_and_sigma"]
    # the fixture compares at 30 m (s01, s02) and 60 m (s03, s04); s04 is unusable
    assert "circles: reference sonic at 30 m (s01 and s02)" in fig12
    assert "triangles: reference sonic at 60 m (s03 and s04)" in fig12
    assert "s04 (hover window" in fig12 and "Ghirardelli et al. (2025), Fig. 12" in fig12
    assert "low_wind_speed" in captions["fig15_quadrant"] and "s02" in captions["fig15_quadrant"]
    assert not any(re.search(r"\bseed \d{3}\b", text) for text in captions.values())
