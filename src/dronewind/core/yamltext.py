"""YAML text to Python objects, with libyaml's parser where PyYAML was built with it.

Every YAML file dronewind reads (campaign manifests, the config schema, published-results
files, extended campaigns) goes through :func:`load_yaml`. PyYAML's pure-Python parser
takes 0.13 CPU-s for the default campaign's 26 kB manifest and libyaml's 0.02 CPU-s with
the same result (both use PyYAML's safe constructor and resolver, so the same tags and
implicit types are allowed); the manifest and the schema are read at every Snakemake start,
i.e. once per job on a cluster.
"""

from __future__ import annotations

from typing import Any

import yaml

__all__ = ["SAFE_LOADER", "load_yaml"]

#: libyaml's safe loader where available, else PyYAML's (identical results).
SAFE_LOADER: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def load_yaml(text: str) -> Any:
    """Parse YAML text with the safe loader (as :func:`yaml.safe_load`).

    Parameters
    ----------
    text : str
        YAML document.

    Returns
    -------
    object
        The document's content (None for an empty document).

    Raises
    ------
    yaml.YAMLError
        Invalid YAML; ``problem_mark`` (0-based line and column) where the parser gives one.

    Examples
    --------
    >>> load_yaml("a: 1\\nb: [x, 2.5]")
    {'a': 1, 'b': ['x', 2.5]}
    """
    return yaml.load(text, Loader=SAFE_LOADER)  # noqa: S506 (a safe loader)
