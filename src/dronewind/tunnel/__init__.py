"""The wind tunnel (seed 002): calibration and verification of the quadrotors.

* :mod:`~dronewind.tunnel.io`: the run index, CTA signals and UAS logs;
* :mod:`~dronewind.tunnel.calibration`: accelerometer offsets, body-axis drag law per speed range,
  accuracy on constant-speed steps (sideslip, portability);
* :mod:`~dronewind.tunnel.metrics`: RMSE, IEC gusts, velocity steps, turbulence limits;
* :mod:`~dronewind.tunnel.analysis`: every table of a tunnel campaign.
"""
