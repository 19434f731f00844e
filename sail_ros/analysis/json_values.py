"""Values as JSON takes them: the one conversion the tools' `--json` outputs share."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def json_number(value) -> float | None:
    """A float for JSON; None for NaN or an infinity (the time of a peak that is 0, a
    divergent mode's period), which JSON lacks."""
    return float(value) if math.isfinite(value) else None


def plain(value):
    """`value` as JSON takes it, through dicts, lists, tuples and arrays: numpy values as
    Python's, paths as text, NaN and infinities as None."""
    if isinstance(value, dict):
        return {key: plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [plain(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return json_number(value)
    if isinstance(value, Path):
        return str(value)
    return value
