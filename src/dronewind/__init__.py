"""dronewind: validation of drone-borne wind and turbulence against mast sonics.

The library is organised one module per physical topic (see ../shared/DESIGN.md):
``io`` (readers), ``filtering``, ``sync``, ``motion``, ``rotation``, ``stats``,
``spectra``, ``uncertainty``, ``scales``, ``quadrotor``, ``tunnel``, ``simulate``,
``mechanisms``, ``diagnose``, ``cf`` (the one NetCDF writer) and ``figures``.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("dronewind")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

__all__ = ["__version__"]
