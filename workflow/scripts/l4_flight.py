"""Snakemake script: L3 -> L4 (statistics, spectra, fits, uncertainties, scales) of every flight's drone and mast."""

from dronewind.steps import l4, logged

sm = snakemake  # noqa: F821 (snakemake is injected)
p = sm.params
with logged(sm.log[0]):
    for flight_id, l3_file, drone, mast in zip(p.flights, sm.input.l3, sm.output.drone, sm.output.mast, strict=True):
        for sensor, output in (("drone", drone), ("mast", mast)):
            l4(l3_file, output, campaign=p.campaign, flight_id=flight_id, sensor=sensor,
               reference=p.references[flight_id], spectra=p.spectra, quadrant=p.quadrant, detrending=p.detrending)
