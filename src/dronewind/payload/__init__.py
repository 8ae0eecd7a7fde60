"""The payload system: a sonic anemometer with an INS (SAMURAI-S sling load).

* :mod:`~dronewind.payload.io`: the logger's sonic and INS files into L1 (logger clock to UTC,
  GNSS time, QC);
* :mod:`~dronewind.payload.motion`: motion correction (Ghirardelli et al. (2025), Eqs 1-2 and App. A);
* :mod:`~dronewind.payload.sync`: sonic-INS lag and the motion-corrected wind, L2
  (Ghirardelli et al. (2025), Sect. 3.3);
* :mod:`~dronewind.payload.chain`: the chain steps (Dataset in, Dataset out) with their
  settings. No file is written here.
"""
