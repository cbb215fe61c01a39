"""The results and selection JSON the repository tracks are strict JSON: no bare
``NaN`` / ``Infinity`` (JavaScript's ``JSON.parse``, ``jq`` and the docs' readers
refuse them); the benchmarks and studies write through ``sparseedm._atomic``'s
``save_json`` / ``json_text``, which write ``null`` there."""

import json
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("benchmarks", "studies")


def tracked_json():
    """The *.json files under benchmarks/ and studies/: git's list when this is a
    checkout, else every one on disk."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--", *FOLDERS], cwd=ROOT,
                             capture_output=True, text=True, check=True, timeout=60).stdout
        files = [ROOT / name for name in out.split("\0") if name.endswith(".json")]
    except (OSError, subprocess.SubprocessError):
        files = []
    return files or sorted(p for folder in FOLDERS for p in (ROOT / folder).rglob("*.json"))


def refuse(constant):
    raise ValueError(f"bare {constant}")


def test_strict_parser_refuses_what_python_accepts():
    """The check itself: Python's json reads NaN, the strict parse does not."""
    assert json.loads('{"a": NaN}')["a"] != 0
    with pytest.raises(ValueError, match="bare NaN"):
        json.loads('{"a": NaN}', parse_constant=refuse)
    assert json.loads('{"a": null}', parse_constant=refuse) == {"a": None}


def test_every_tracked_json_is_strict():
    files = tracked_json()
    if not files:
        pytest.skip("no JSON under benchmarks/ or studies/ (not a source checkout)")
    bad = []
    for path in files:
        if not path.is_file():  # listed by git, deleted in the work tree
            continue
        try:
            json.loads(path.read_text(encoding="utf-8"), parse_constant=refuse)
        except ValueError as err:
            bad.append(f"{path.relative_to(ROOT)}: {err}")
    assert not bad, (
        "not strict JSON; rewrite them with `python -m studies.results_json --rewrite FILE...` "
        "(NaN and infinities as null, nothing else changed) and write them through "
        "sparseedm._atomic.save_json / json_text:\n" + "\n".join(bad))
