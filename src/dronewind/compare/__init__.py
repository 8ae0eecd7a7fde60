"""Drone against mast: alignment, decimation and rotation (L3), statistics per sensor (L4).

:mod:`~dronewind.compare.l4` builds the L4 products (statistics, spectra, fits, quadrant
ratios, uncertainties and length scales of one sensor of one flight).
"""
