"""Figures drawn from stored products (NetCDF, CSV and JSON) only; they compute nothing.

Ghirardelli et al. (2025) campaign figures, one module per topic: :mod:`~dronewind.figures.synchronisation`
(Fig. 4), :mod:`~dronewind.figures.positions` (Fig. 7), :mod:`~dronewind.figures.timeseries`
(Figs 8, 10), :mod:`~dronewind.figures.spectra` (Figs 9, 11, B1, B2),
:mod:`~dronewind.figures.statistics` (Figs 12, 14), :mod:`~dronewind.figures.fluxes`
(Figs 13, 16), :mod:`~dronewind.figures.quadrant` (Fig. 15); their registry and
:func:`~dronewind.figures.campaign.draw_all` in :mod:`~dronewind.figures.campaign`, the names
and captions of every figure the workflow makes in :mod:`~dronewind.figures.labels`; the
shared look (canvas, colours, unit labels, notes, saving) in :mod:`~dronewind.figures.style`
and the drone-vs-mast panels in :mod:`~dronewind.figures.scatter`.

Diagnosis figures: :mod:`~dronewind.figures.diagnosis` (campaign diagnosis) and
:mod:`~dronewind.figures.published` (diagnosis of the published numbers).
:mod:`~dronewind.figures.quadrotor`: SWUF-3D and wind-tunnel figures.
"""
