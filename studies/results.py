"""Reading the results JSON of studies/ and benchmarks/ for their tables.

They are written as strict JSON (:func:`sparseedm._atomic.json_text`: NaN and
infinities as ``null``); a table reads a ``null`` back as NaN, as it reads a
number it has no value for (``python -m studies.results FILE`` prints one so).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path


def nan_for_null(obj):
    """`obj` with every ``None`` (a JSON ``null``) as NaN.

    >>> nan_for_null({"mean": None, "rows": [1.5, None]})
    {'mean': nan, 'rows': [1.5, nan]}
    """
    if obj is None:
        return math.nan
    if isinstance(obj, dict):
        return {k: nan_for_null(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [nan_for_null(v) for v in obj]
    return obj


def load_results(path):
    """A results JSON file, its ``null`` values as NaN (:func:`nan_for_null`)."""
    return nan_for_null(json.loads(Path(path).read_text(encoding="utf-8")))


if __name__ == "__main__":
    for name in sys.argv[1:]:
        print(load_results(name))
