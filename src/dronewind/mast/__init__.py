"""The mast/tower system: sonic anemometers on a fixed mast.

Campbell TOA5 files of CSAT3 sonics into L1 (:mod:`~dronewind.mast.toa5`) and the
AmeriFlux/Gill RAW text (:mod:`~dronewind.mast.ameriflux`).
"""
