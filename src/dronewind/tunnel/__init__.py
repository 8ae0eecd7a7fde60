"""The wind tunnel (Kistner et al. (2024)): calibration and verification of the quadrotors.

* :mod:`~dronewind.tunnel.io`: the run index, CTA signals and UAS logs;
* :mod:`~dronewind.tunnel.calibration`: accelerometer offsets, body-axis drag law per speed range,
  accuracy on constant-speed steps (sideslip, portability);
* :mod:`~dronewind.tunnel.metrics`: RMSE, IEC gusts, velocity steps, turbulence limits;
* :mod:`~dronewind.tunnel.analysis`: every table of a tunnel campaign.
"""

__all__ = ["TUNNEL_TABLES"]

#: Tables of a tunnel campaign, in the order they are written (``tunnel_<name>.csv``,
#: :func:`dronewind.tunnel.analysis.analyse_tunnel`); here, apart from the analysis and its
#: scipy, for the Snakefile that lists them as outputs.
TUNNEL_TABLES: tuple[str, ...] = (
    "offsets", "calibration", "steps_accuracy", "sideslip", "portability", "gusts", "gust_summary",
    "steps", "step_summary", "turbulence", "turbulence_summary",
)
