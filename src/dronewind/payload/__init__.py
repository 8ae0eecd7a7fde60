"""The payload system: a sonic anemometer with an INS (SAMURAI-S sling load).

* :mod:`~dronewind.payload.reader`: the logger's sonic and INS files (L0) with their faults;
* :mod:`~dronewind.payload.clock`: the logger clock to UTC on the INS's GNSS time;
* :mod:`~dronewind.payload.ins`, :mod:`~dronewind.payload.sonic`: INS and sonic L1 (QC);
* :mod:`~dronewind.payload.motion`: motion correction (Ghirardelli et al. (2025), Eqs 1-2 and App. A);
* :mod:`~dronewind.payload.lag_search`: the sonic-INS lag of minimum TKE (Ghirardelli et al. (2025), Sect. 3.3);
* :mod:`~dronewind.payload.l2`: hover window, gap filling and the motion-corrected wind, L2;
* :mod:`~dronewind.payload.chain`: the chain steps (Dataset in, Dataset out) with their
  settings. No file is written here.
"""
