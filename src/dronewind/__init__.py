"""dronewind: validation of drone-borne wind and turbulence against mast sonics.

The library is organised one module per physical topic (see ../shared/DESIGN.md):
``io`` (readers), ``filtering``, ``sync``, ``motion``, ``rotation``, ``stats``,
``spectra``, ``uncertainty``, ``scales``, ``quadrotor``, ``tunnel``, ``simulate``,
``mechanisms``, ``diagnose``, ``cf`` (the one NetCDF writer) and ``figures``.
"""

__all__ = ["__version__", "open_product"]

__version__: str  # set by __getattr__ when first asked for


def __getattr__(name: str) -> object:
    """``__version__`` (looked up in the installed metadata when first asked for, PEP 562) and
    :func:`dronewind.core.products.open_product` (imported when first asked for).

    Importing :mod:`importlib.metadata` and finding the distribution costs a process about
    0.07 CPU-s; every workflow job's process and every Snakemake start imports this package,
    and most never ask for the version.
    """
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            found = version("dronewind")
        except PackageNotFoundError:  # running from a source tree without installation
            found = "0+unknown"
        globals()["__version__"] = found
        return found
    if name == "open_product":  # one call for a product with its groups (docs/outputs.md)
        from dronewind.core.products import open_product

        return open_product
    raise AttributeError(f"module 'dronewind' has no attribute {name!r}")
