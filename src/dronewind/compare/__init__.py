"""Drone against mast: alignment, decimation and rotation (L3), statistics per sensor (L4).

* :mod:`~dronewind.compare.align`: anti-alias FIR decimation, drone-mast advection lag and
  the L3 builder (Ghirardelli et al. (2025), Sect. 4.4);
* :mod:`~dronewind.compare.l4`: statistics, spectra, fits, quadrant ratios, uncertainties
  and length scales of one sensor of one flight (Ghirardelli et al. (2025), Sect. 4 and 5);
* :mod:`~dronewind.compare.chain`: the chain steps (Dataset in, Dataset out) with their
  settings;
* :mod:`~dronewind.compare.blocks`: tower and mast records in UTC-aligned blocks (30 min by
  default), each through the L4 of a flight's mast sensor, and the rows of
  ``block_stats.csv`` (here, not in :mod:`dronewind.mast`, because it reuses the L4, which
  sits above the instrument packages in the layers);
* :mod:`~dronewind.compare.long_record`: long records (a month of 20 Hz daily TOA5 files)
  file by file with dask in bounded memory: L1 per file with the neighbours' rows as
  despiking context, blocks, ``block_stats.csv``.
"""
