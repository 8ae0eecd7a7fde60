"""dronewind: validation of drone-borne wind and turbulence against mast sonics.

The library is a core of kernels (``core``) with one package per instrument system above it
(``payload``, ``mast``, ``quadrotor``, ``tunnel``), the drone-mast comparison (``compare``),
the virtual campaign (``simulate``), the diagnosis (``diagnose``), figures, tables and the
workflow steps on top; the real records are reached through ``datasets``. Design, data
levels and data contract: docs/design.md and docs/data-contract.md.
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
