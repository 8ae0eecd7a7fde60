"""The payload system: a sonic anemometer with an INS (SAMURAI-S sling load).

Readers of the logger's sonic and INS files into L1 (:mod:`~dronewind.payload.io`), motion
correction (:mod:`~dronewind.payload.motion`, seed 000 Eqs 1-2 and App. A) and the
synchronisation of sonic and INS into motion-corrected wind, L2
(:mod:`~dronewind.payload.sync`). Datasets in, datasets out; no file is written here.
"""
