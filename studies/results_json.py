"""Reading the results JSON of studies/ and benchmarks/ for their tables.

They are written as strict JSON (:func:`sparseedm._atomic.json_text`: NaN and
infinities as ``null``); a table reads a ``null`` back as NaN, as it reads a
number it has no value for (``python -m studies.results_json FILE`` prints one so).
``python -m studies.results_json --rewrite FILE...`` rewrites files that hold bare
``NaN`` / ``Infinity`` as strict JSON in their own layout (indent 1 or compact),
every other value as it was (tests/test_tracked_json.py asks for it).
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


def rewrite_strict(path):
    """Rewrite `path` as strict JSON if it holds a bare NaN or infinity; True if it did.

    The layout kept: ``json.dumps``' indent 1 or compact separators, and a
    trailing newline if the file had one (any other layout: indent 1).
    """
    from sparseedm._atomic import json_text

    path = Path(path)
    text = path.read_text(encoding="utf-8")
    obj = json.loads(text)
    if json_text(obj) == json.dumps(obj, allow_nan=True):
        return False
    end = "\n" if text.endswith("\n") else ""
    layout = dict(indent=1)
    if json.dumps(obj, separators=(",", ":")) + end == text:
        layout = dict(separators=(",", ":"))
    path.write_text(json_text(obj, **layout) + end, encoding="utf-8")
    return True


if __name__ == "__main__":
    if sys.argv[1:2] == ["--rewrite"]:
        for name in sys.argv[2:]:
            if rewrite_strict(name):
                print(f"rewrote {name}")
    else:
        for name in sys.argv[1:]:
            print(load_results(name))
