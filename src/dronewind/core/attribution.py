"""Who made a campaign's products and under which licence they are shared.

A light module (no scientific library): the workflow reads the manifest's ``creator:`` and
``license:`` when it starts (``workflow/rules/common.smk``) and hands them to the L1 steps;
:func:`dronewind.core.cf.write_netcdf` writes them and every later level inherits them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["ATTRIBUTION_KEYS", "attribution"]

#: The attributes of a product that say who made the data and under which licence they are
#: shared. The defaults of every product (:mod:`dronewind.core.cf`) apply unless the campaign
#: manifest sets them (``creator:``, ``license:``, :func:`attribution`); the L1 steps state them
#: and every later level inherits them from its inputs, like ``source``. The outputs' licence
#: is CC-BY-4.0 by default; the code's is MIT (LICENSE).
ATTRIBUTION_KEYS: tuple[str, ...] = ("creator_name", "creator_email", "creator_url", "creator_type",
                                     "creator_institution", "institution", "license")


def attribution(creator: Mapping[str, Any] | None = None, license: str | None = None) -> dict[str, str]:
    """The attribution attributes of a campaign's products from its manifest.

    Parameters
    ----------
    creator : mapping, optional
        Manifest ``creator``: ``name``, ``email``, ``institution``, ``url`` (each optional).
    license : str, optional
        Manifest ``license``: the licence of the products (e.g. ``CC-BY-4.0``, ``CC0-1.0``).

    Returns
    -------
    dict
        ``creator_name``, ``creator_email``, ``creator_url``, ``creator_type`` (``person``),
        ``creator_institution`` and ``institution`` (the creator's institution), ``license``:
        only those the manifest sets (the rest keep the defaults of every product).
    """
    out: dict[str, str] = {}
    for key in ("name", "email", "url", "institution"):
        if (creator or {}).get(key):
            out[f"creator_{key}"] = str(creator[key])  # type: ignore[index]
    if "creator_name" in out:
        out["creator_type"] = "person"
    if "creator_institution" in out:
        out["institution"] = out["creator_institution"]
    if license:
        out["license"] = str(license)
    return out
