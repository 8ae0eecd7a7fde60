"""Figures drawn from stored products (NetCDF and CSV) only; they compute nothing.

:mod:`~dronewind.figures.payload` (seed 000 Figs 4, 7-16, B1-B2),
:mod:`~dronewind.figures.quadrotor` (SWUF-3D and wind-tunnel figures).
"""
