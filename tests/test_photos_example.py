"""The shipped photos example (examples/coco_photos.json): what its docs say it
holds, README.md's Python block on it, and its rebuild from ../shared."""

import json
import re
from pathlib import Path

import numpy as np

from sparseedm.keypoints import read_keypoints

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "coco_photos.json"


def test_it_holds_what_its_docs_say():
    doc = json.loads(EXAMPLE.read_text(encoding="utf-8"))
    n_people, n_images = len(doc["annotations"]), len({im["id"] for im in doc["images"]})
    assert len(doc["images"]) == n_images  # each image once
    said = f"{n_people} people of {n_images} COCO photos"
    assert said in " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    tutorial = (ROOT / "docs" / "tutorials" / "00_photos.py").read_text(encoding="utf-8")
    assert f"{n_people} people in {n_images} COCO photos" in " ".join(tutorial.split())
    assert "CC BY 4.0" in doc["info"]["description"]
    kps = read_keypoints(EXAMPLE)
    assert len(kps.poses) == n_people and kps.frames is None
    assert kps.missing.any(axis=1).sum() > 0 and (~kps.missing.any(axis=1)).sum() >= 50


def test_the_readme_photos_snippet_runs_as_written(monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    block = [b for b in blocks if "examples/coco_photos.json" in b]
    assert len(block) == 1
    monkeypatch.chdir(ROOT)
    scope = {}
    exec(compile(block[0], "README.md (photos)", "exec"), scope)
    res, kps = scope["res"], scope["kps"]
    seen = ~kps.missing & res.ok[:, None]          # a refused pose comes back NaN
    assert res.ok.sum() > len(res.ok) / 2 and np.isnan(res.poses[~res.ok]).all()
    np.testing.assert_array_equal(res.poses[seen], kps.poses[seen])
    assert scope["filled"].sum() > 0 and np.isfinite(res.poses[scope["filled"]]).all()
    assert "joints filled" in capsys.readouterr().out


def test_the_example_is_rebuilt_identically(shared_data, tmp_path, monkeypatch):
    """examples/make_photos_example.py regenerates the file byte for byte."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_photos_example",
                                                  ROOT / "examples" / "make_photos_example.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "OUTPUT", tmp_path / "coco_photos.json")
    module.main(["--data-dir", str(shared_data)])
    assert (tmp_path / "coco_photos.json").read_bytes() == EXAMPLE.read_bytes()
