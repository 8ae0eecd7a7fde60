"""Kernels shared by every instrument system; the core imports nothing of the systems.

* :mod:`~dronewind.core.constants`: physical constants (von Karman, gravity, dry air, WGS84) and the
  published drag coefficients (Wetz et al. 2021, Eq. 18; Kistner et al. 2024, Table 2), once;
* :mod:`~dronewind.core.surface_layer`: Monin-Obukhov similarity (stability functions, profiles,
  standard deviations), shared by the simulator and the diagnosis' forward model;
* :mod:`~dronewind.core.geo`: the one local tangent-plane projection (WGS84) and its inverse;
* :mod:`~dronewind.core.qc`: QC bit flags and L4 status flags, once, with their CF attributes;
* :mod:`~dronewind.core.timeseries`: time stamps, gap runs and NaN filling of sampled series;
* :mod:`~dronewind.core.filtering`: instrument range limits, moving-MAD despiking, gap filling,
  hover windows;
* :mod:`~dronewind.core.rotation`: single, double, triple rotation and planar fit;
* :mod:`~dronewind.core.stats`: moments, fluxes, friction velocity, Obukhov length;
* :mod:`~dronewind.core.spectra`: Welch spectra, log-bin smoothing and the spectral models;
* :mod:`~dronewind.core.scales`: integral time and length scales;
* :mod:`~dronewind.core.uncertainty`: sampling uncertainties;
* :mod:`~dronewind.core.cf`: the CF variable builder and the CF/ACDD NetCDF product writer;
* :mod:`~dronewind.core.cf_names`: library names <-> CF names of the products;
* :mod:`~dronewind.core.products`: the reader of stored products (NetCDF, CSV) for figures
  and tables;
* :mod:`~dronewind.core.yamltext`: YAML text to objects (libyaml's safe loader where built).
"""
