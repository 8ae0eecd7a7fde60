"""Drone against mast: alignment, decimation and rotation (L3), statistics per sensor (L4).

* :mod:`~dronewind.compare.align`: anti-alias FIR decimation, drone-mast advection lag and
  the L3 builder (seed 000, Sect. 4.4);
* :mod:`~dronewind.compare.l4`: statistics, spectra, fits, quadrant ratios, uncertainties
  and length scales of one sensor of one flight (seed 000, Sect. 4 and 5);
* :mod:`~dronewind.compare.chain`: the chain steps (Dataset in, Dataset out) with their
  settings.
"""
