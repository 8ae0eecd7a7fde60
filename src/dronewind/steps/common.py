"""Orchestration shared by every workflow step: logging, campaign record, product reader."""

from __future__ import annotations

import contextlib
import json
import logging
import sys
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from dronewind import __version__
from dronewind.manifest import load_campaign

LOG = logging.getLogger("dronewind")


def __getattr__(name: str) -> Any:
    """``open_product`` (:func:`dronewind.core.products.open_product`), imported when first asked for.

    Steps and scripts read products through this module; the Snakefile imports it (through
    the steps whose settings it reads) at every Snakemake start, where the product reader's
    xarray would cost a few tenths of a CPU-second for nothing.
    """
    if name == "open_product":
        from dronewind.core.products import open_product

        return open_product
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _process_usage() -> str:
    """CPU time and peak memory of this process since it started (imports included).

    A workflow job is one process, so this is the whole job. Snakemake's benchmark file samples
    the job's process (every 0.5 s at first, then every 30 s) and misses what the process used
    after its last sample; the job's log states the exact figures.
    """
    usage = f"process: {time.process_time():.2f} CPU-s"
    try:
        import resource
    except ImportError:  # pragma: no cover - not on Windows
        return usage
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / (2**20 if sys.platform == "darwin" else 2**10)
    return f"{usage}, peak {peak_mb:.0f} MB"


@contextlib.contextmanager
def logged(log_file: str | Path | None) -> Iterator[logging.Logger]:
    """Send dronewind's log (and Python warnings) to a file for the duration of a step.

    Parameters
    ----------
    log_file : str or Path or None
        Log file (created with its folder); ``None`` logs to standard error only.

    Yields
    ------
    logging.Logger
        The ``dronewind`` logger.
    """
    handlers: list[logging.Handler] = [logging.StreamHandler(sys.stderr)]
    if log_file is not None:
        Path(log_file).parent.mkdir(parents=True, exist_ok=True)
        handlers.append(logging.FileHandler(log_file, mode="w", encoding="utf-8"))
    fmt = logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s")
    for handler in handlers:
        handler.setFormatter(fmt)
        LOG.addHandler(handler)
    LOG.setLevel(logging.INFO)
    logging.captureWarnings(True)
    warn_logger = logging.getLogger("py.warnings")
    for handler in handlers:
        warn_logger.addHandler(handler)
    start = time.perf_counter()
    try:
        yield LOG
        LOG.info("done in %.2f s; %s", time.perf_counter() - start, _process_usage())
    except Exception:
        LOG.exception("failed after %.2f s", time.perf_counter() - start)
        raise
    finally:
        for handler in handlers:
            LOG.removeHandler(handler)
            warn_logger.removeHandler(handler)
            handler.close()
        logging.captureWarnings(False)


def campaign_record(manifest: str | Path, output: str | Path, config: Mapping[str, Any]) -> Path:
    """Validate a manifest and record it with provenance as JSON.

    Parameters
    ----------
    manifest : str or Path
        Campaign manifest.
    output : str or Path
        JSON file to write (``results/<name>/campaign.json``).
    config : mapping
        Workflow configuration (hashed into the record, without ``results_dir``).

    Returns
    -------
    Path
        The written file.
    """
    from dronewind.core.cf import atomic_write_text, config_hash, sha256_file

    campaign = load_campaign(manifest)
    record: dict[str, Any] = {
        "campaign": campaign.name,
        "manifest": str(campaign.path),
        "manifest_sha256": sha256_file(campaign.path),
        "simulated": campaign.simulated,
        "dronewind_version": __version__,
        # where the results lie is not a setting: identical runs in two folders record one hash
        "config_sha256": config_hash({k: v for k, v in config.items() if k != "results_dir"}),
        "payload_flights": [f["id"] for f in campaign.payload_flights],
        "quadrotor_flights": [f["id"] for f in campaign.quadrotor_flights],
        "mast_sonics": sorted(campaign.mast_sonics()),
        "manifest_content": campaign.data,
    }
    LOG.info(
        "campaign %s: %d payload flight(s), %d quadrotor flight(s), %d mast sonic(s)",
        campaign.name,
        len(record["payload_flights"]),
        len(record["quadrotor_flights"]),
        len(record["mast_sonics"]),
    )
    return atomic_write_text(output, json.dumps(record, indent=2, sort_keys=True) + "\n")
