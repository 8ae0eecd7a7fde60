"""Kernels shared by every instrument system.

Statistics (:mod:`~dronewind.core.stats`), spectra and their model fits
(:mod:`~dronewind.core.spectra`), integral scales (:mod:`~dronewind.core.scales`), sampling
uncertainties (:mod:`~dronewind.core.uncertainty`), coordinate rotations
(:mod:`~dronewind.core.rotation`), filtering and quality control
(:mod:`~dronewind.core.filtering`), and the CF/ACDD NetCDF product writer and reader
(:mod:`~dronewind.core.cf`). The core imports nothing of the instrument systems.
"""
