"""The wind tunnel (seed 002): calibration and verification of the quadrotors.

:mod:`~dronewind.tunnel.analysis`: sideslip, portability, IEC gusts, velocity steps and
turbulence limits.
"""
