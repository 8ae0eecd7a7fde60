"""Names shared by the figures, their captions and the report, without matplotlib.

The captions and the report pages cite the papers and describe the markers; they import
these names from here, so that a job writing the report does not import matplotlib
(:mod:`dronewind.figures.style` re-exports them for the figures). The names and captions of
the figures the workflow makes are here too: the Snakefile lists its outputs from them each
time Snakemake starts, without a plotting library.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["HEIGHT_MARKERS", "PAPERS", "REFERENCES", "PathLike", "figure_captions", "BLOCK_FIGURE",
           "QUAD_FIGURES", "TUNNEL_FIGURES", "REPORT_TABLES", "APPENDIX_FIGURES"]

PathLike = str | Path

#: Markers of the reference heights, lowest first (Ghirardelli et al. (2025): circles 30 m, triangles 60 m).
HEIGHT_MARKERS = ("o", "^", "s", "D", "v", "P")

#: The three papers the project follows, cited by
#: authors and year in captions and reports.
PAPERS = {
    "000": "Ghirardelli et al. (2025)",
    "001": "Wetz et al. (2021)",
    "002": "Kistner et al. (2024)",
}
#: Full references of :data:`PAPERS`, for the report.
REFERENCES = {
    "000": "Ghirardelli, M., Kral, S. T., Cheynet, E., and Reuder, J.: SAMURAI-S: Sonic Anemometer on a "
           "Multi-Rotor drone for Atmospheric turbulence Investigation in a Sling load configuration, "
           "Atmos. Meas. Tech., 2025.",
    "001": "Wetz, T., Wildmann, N., and Beyrich, F.: Distributed wind measurements with multiple quadrotor "
           "unmanned aerial vehicles in the atmospheric boundary layer, Atmos. Meas. Tech., 14, 3795-3814, 2021.",
    "002": "Kistner, J., Neuhaus, L., and Wildmann, N.: High resolution wind speed measurements with quadcopter "
           "UAS: calibration and verification in a wind tunnel with active grid, Atmos. Meas. Tech., 2024.",
}


def figure_captions() -> dict[str, str]:
    """Captions of the campaign figures, keyed by figure name (= function name = output stem).

    Returns
    -------
    dict of str to str
        Name -> what the figure shows, independent of any campaign (plain text). The
        report's captions say what a campaign's figure shows:
        :func:`dronewind.figures.captions.campaign_captions`.
    """
    P000 = PAPERS["000"]  # noqa: N806 (the name the captions cite)
    return {
        "fig04_tke_lag": "Turbulent kinetic energy of the motion-corrected payload wind versus the lag added to "
        "the sonic clock relative to the INS, one curve per flight, each normalised by its minimum (after "
        f"{P000}, Fig. 4). Dashed and dash-dot vertical lines: smallest and largest lag of minimum TKE among "
        "the usable flights. Unusable flights grey, dashed.",
        "fig07_positions": "Left: payload height above ground (GNSS altitude minus site altitude) during the "
        "hover windows, with the mast sonic heights dotted. Right: payload position east/north of the mast, "
        "sonic head azimuths as black lines; coloured arrows from the median position point where the wind "
        "measured by the reference mast sonic blows to, its mean speed and direction in the legend "
        f"(after {P000}, Fig. 7).",
        "fig08_timeseries": "Streamwise (u), cross-wind (v) and vertical (w) velocity in streamline coordinates "
        "(L3, 8 Hz), drone (blue) and reference mast sonic (orange), for the detailed flights; titles give the "
        f"heights and mean speeds from L4 (after {P000}, Fig. 8).",
        "fig09_velocity_spectra": "Frequency-weighted spectra f S_u, f S_v, f S_w (log-log) and co-spectrum "
        "f Re(S_uw) (linear y), drone (blue) and mast (orange), with the blunt/pointed model fitted to the drone "
        f"(black, {P000} Eqs 4-7); standard deviations and u'w' in the panel titles (after {P000}, Fig. 9).",
        "fig10_temperature_series": "Sonic temperature fluctuations (minus the stored mean of each sensor), "
        f"drone (blue) and mast (orange), for the detailed flights; the means are in the legend (after {P000}, "
        "Fig. 10).",
        "fig11_temperature_spectra": "Frequency-weighted sonic-temperature spectrum f S_theta (log-log) and "
        "co-spectra f Re(S_w theta) and f Re(S_u theta) (linear y), drone (blue) and mast (orange) (after "
        f"{P000}, Fig. 11).",
        "fig12_mean_and_sigma": "Drone versus mast mean wind speed and standard deviations of u, v, w, one colour "
        "per flight, one marker per reference height (lowest first: circles, triangles, squares); dashed: "
        f"1:1 (after {P000}, Fig. 12).",
        "fig13_fluxes_obukhov": "Drone versus mast covariances u'w', v'w', w'theta_v' and Obukhov length L "
        f"(symmetric-log axes); markers as in Fig. 12 (after {P000}, Fig. 13).",
        "fig14_length_scales": "Drone versus mast integral length scales L_u, L_v, L_w (exponential fit of the "
        "autocovariance and Taylor's hypothesis); flights where I_u >= 0.5 or U <= 1 m s⁻¹ are left out and listed "
        f"(after {P000}, Fig. 14).",
        "fig15_quadrant": "Quadrant analysis of the frequency-averaged spectral ratios <S_w/S_u> (left) and "
        "<S_v/S_u> (right) over 2 < f z/U < 10, drone versus mast, coloured by the mast mean speed; lines at the "
        f"isotropic 4/3; grey triangles: mean speed below the low-wind limit (after {P000}, Figs 6 and 15).",
        "fig16_uncertainty": f"Normalised random-uncertainty metrics ({P000} Eqs 10-13) of the variances, "
        "momentum fluxes and buoyancy flux, drone (y) versus mast (x); green: below 0.5, low statistical "
        f"uncertainty (after {P000}, Fig. 16).",
        "figB1_normalised_velocity_spectra": "Spectra of u, v, w normalised by their variances, and the u-w "
        "co-spectrum normalised by u'w', drone (blue) and mast (orange), for the flights not shown in detail "
        f"(after {P000}, Fig. B1).",
        "figB2_normalised_temperature_spectra": "Sonic-temperature spectrum normalised by its variance and the "
        "w-theta and u-theta co-spectra normalised by their covariances, drone (blue) and mast (orange), for the "
        f"flights not shown in detail (after {P000}, Fig. B2).",
    }


#: Name of the block-series figure (output stem and report key; :mod:`dronewind.figures.blocks`).
BLOCK_FIGURE = "block_series"

#: The normalised spectra of Appendix B of Ghirardelli et al. (2025): the workflow draws them in a
#: job of their own (``figures_appendix``), as they take about as long as all the other campaign
#: figures together.
APPENDIX_FIGURES = ("figB1_normalised_velocity_spectra", "figB2_normalised_temperature_spectra")

#: Quadrotor figures: file stem -> caption.
QUAD_FIGURES: dict[str, str] = {
    "quadrotor_fig3_individual": "10-min wind speed, drone vs tower, individual calibration (Wetz et al. 2021, Fig. 3)",
    "quadrotor_fig4_regression": "Tilt vs tower wind speed and the universal regression law (Wetz et al. 2021, Fig. 4)",
    "quadrotor_fig5_validation": "Validation flights, drone vs tower with universal law and calibrated offsets "
                                 "(Wetz et al. (2021), Fig. 5)",
    "quadrotor_fig6_direction": "Wind direction, drone (corrected heading) vs tower (Wetz et al. (2021), Fig. 6)",
    "quadrotor_fig7_timeseries": "1 Hz UAV wind speed and tower 1-min means of one flight (Wetz et al. (2021), Fig. 7)",
    "quadrotor_fig8_profiles": "Wind-speed profiles, drones (with calibration RMSE) vs tower "
                               "(Wetz et al. 2021, Fig. 8)",
    "quadrotor_fig9_variance": "Variance of 1-min mean speeds in each window, drone vs tower (Wetz et al. 2021, Fig. 9 "
                               "analogue: the tower reports 1-min means)",
}
#: Tunnel figures: file stem -> caption.
TUNNEL_FIGURES: dict[str, str] = {
    "tunnel_fig4_sideslip": "RMSE of the UAS speed over the CTA speed per angle of sideslip "
                            "(Kistner et al. 2024, Fig. 4)",
    "tunnel_fig5_portability": "Speed error of each UAS over the CTA speed (Kistner et al. (2024), Fig. 5)",
    "tunnel_fig6_gusts": "Gust RMSE at V0 and at the peak Vp per preset (Kistner et al. (2024), Fig. 6)",
    "tunnel_fig7_steps": "Velocity-step RMSEs per preset (Kistner et al. (2024), Fig. 7)",
    "tunnel_fig9_variance": "Variance, UAS vs CTA at full and cut bandwidth (Kistner et al. (2024), Fig. 9)",
}


#: Tables shown in the report: name -> (title, source file relative to ``results/<name>/``).
REPORT_TABLES: dict[str, tuple[str, str]] = {
    "validation": ("Drone against mast: bias, RMSE and slope per statistic", "tables/validation.md"),
    "table4_flights": ("Table 4: the payload flights", "tables/table4_flights.md"),
    "table5_statistics": ("Table 5: mean and turbulent statistics, drone and mast", "tables/table5_statistics.md"),
    "flight_stats": ("Flight statistics, drone and mast (flight_stats.csv)", "tables/flight_stats.csv"),
    "diagnosis_evidence": ("Diagnosis: residuals, candidates, before and after", "diagnosis/report.md"),
    "published_numbers": ("The paper's published numbers: diagnosis and before/after", "published/report.md"),
    "quadrotor_calibration": ("Quadrotor calibration per UAV (quadrotor_calibration.csv)",
                              "tables/quadrotor_calibration.csv"),
    "quadrotor_table2": (f"Quadrotor validation, individual and universal calibration ({PAPERS['001']}, Table 2)",
                         "tables/quadrotor_table2.csv"),
    "quadrotor_table3": (f"Quadrotor calibration scenarios a-d ({PAPERS['001']}, Table 3)",
                         "tables/quadrotor_table3.csv"),
    "tunnel_calibration": (f"Wind-tunnel calibration per speed range ({PAPERS['002']}, Table 2)",
                           "tables/tunnel_calibration.csv"),
    "block_stats": ("Tower and mast records in blocks (block_stats.csv)", "tables/block_stats.csv"),
}
