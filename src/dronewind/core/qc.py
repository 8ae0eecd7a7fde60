"""Quality-control flag bits and status flags: one definition for every product.

Sample-level QC is a bit mask (CF ``flag_masks``): a sample may carry several flags at
once. Product-level status (L4 quantities) is an enumeration (CF ``flag_values``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

#: Value outside the instrument's measurement range.
QC_OUT_OF_RANGE: int = 1
#: Spike (moving-MAD despiking).
QC_SPIKE: int = 2
#: Missing, non-numeric or corrupt sample.
QC_MISSING: int = 4
#: Gap filled by interpolation.
QC_GAP_FILLED: int = 8
#: CSAT3 diagnostic word non-zero.
QC_DIAG: int = 16

#: Meaning of each QC bit, in bit order (CF ``flag_meanings`` words).
QC_MEANINGS: dict[int, str] = {
    QC_OUT_OF_RANGE: "out_of_range",
    QC_SPIKE: "spike",
    QC_MISSING: "missing_or_corrupt",
    QC_GAP_FILLED: "gap_filled",
    QC_DIAG: "csat3_diagnostic",
}

#: Status of an L4 quantity (CF ``flag_values``: index = value), shared by every ``status_*`` variable.
STATUS_FLAG_MEANINGS: tuple[str, ...] = (
    "ok",
    "invalid_input",
    "record_too_short",
    "fit_not_converged",
    "low_wind_speed",
    "taylor_hypothesis_invalid",
    "band_not_resolved",
    "above_uncertainty_threshold",
    "undefined",
)


def qc_flag_attrs(
    long_name: str,
    bits: Sequence[int] = (QC_OUT_OF_RANGE, QC_SPIKE, QC_MISSING, QC_GAP_FILLED),
    dtype: npt.DTypeLike = np.int8,
    with_values: bool = True,
) -> dict[str, Any]:
    """CF attributes of a QC bit-mask variable.

    Parameters
    ----------
    long_name : str
        Long name of the QC variable.
    bits : sequence of int
        The bits the variable can carry (from this module's ``QC_*``).
    dtype : numpy dtype
        Type of the QC variable (``flag_masks`` must have the variable's type, CF 3.5).
    with_values : bool
        Also write ``flag_values`` equal to the masks (each bit read as a value).

    Returns
    -------
    dict
        ``standard_name``, ``long_name``, ``flag_masks`` [, ``flag_values``],
        ``flag_meanings`` and ``units``.
    """
    masks = np.array(list(bits), dtype=dtype)
    attrs: dict[str, Any] = {"standard_name": "status_flag", "long_name": long_name, "flag_masks": masks}
    if with_values:
        attrs["flag_values"] = masks.copy()
    attrs["flag_meanings"] = " ".join(QC_MEANINGS[int(b)] for b in bits)
    attrs["units"] = "1"
    return attrs


__all__ = [
    "QC_DIAG",
    "QC_GAP_FILLED",
    "QC_MEANINGS",
    "QC_MISSING",
    "QC_OUT_OF_RANGE",
    "QC_SPIKE",
    "STATUS_FLAG_MEANINGS",
    "qc_flag_attrs",
]
