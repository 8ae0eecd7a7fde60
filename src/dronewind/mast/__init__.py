"""The mast/tower system: sonic anemometers on a fixed mast.

* :mod:`~dronewind.mast.toa5`: Campbell TOA5 files of CSAT3 sonics, with their faults;
* :mod:`~dronewind.mast.level1`: the CSAT3 record on its grid in ENU with QC (L1);
* :mod:`~dronewind.mast.ameriflux`: the AmeriFlux/Gill RAW text;
* :mod:`~dronewind.mast.chain`: mast L1 with its planar fit and the cut to a flight (L2).
"""
