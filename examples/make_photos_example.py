"""Regenerate examples/coco_photos.json: real people in photos, as COCO annotates them.

    python examples/make_photos_example.py [--data-dir ../shared/data]

The people of the COCO 2017 validation images that the project's real-people
split (``benchmarks/real2d.py``: ``split(...) == "val"``, by image) puts in
``val``: every non-crowd person with at least one keypoint, as the COCO
keypoint annotations give them (x, y, v per keypoint; v = 0 where the joint is
not annotated, hidden or out of the image), and their images' ids and sizes
(each image once).
Nothing else is kept (no segmentation, no image). None of these people is in
a shipped dictionary (``cmu-coco-k2466`` and ``cmu-coco-k2932`` hold the
``train`` images' people).

COCO 2017 keypoint annotations © COCO Consortium, licensed CC BY 4.0
(https://cocodataset.org, https://creativecommons.org/licenses/by/4.0/).
"""

import argparse
import gzip
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
OUTPUT = HERE / "coco_photos.json"
SOURCE = Path("real2d") / "coco-val2017-subset" / "person_keypoints_val2017.json.gz"
ATTRIBUTION = ("COCO 2017 keypoint annotations (val2017), (c) COCO Consortium, licensed "
               "CC BY 4.0 (https://cocodataset.org); the people of the images that "
               "sparseedm's real-people split puts in 'val', keypoints only")
KEEP = ("id", "image_id", "category_id", "keypoints", "num_keypoints", "bbox", "area",
        "iscrowd")


def example(data_dir):
    """The example's COCO document."""
    sys.path.insert(0, str(ROOT))
    from benchmarks import real2d

    with gzip.open(Path(data_dir) / SOURCE, "rt", encoding="utf-8") as f:
        doc = json.load(f)
    anns = [a for a in doc["annotations"] if not a.get("iscrowd") and a.get("num_keypoints", 0) > 0]
    people = real2d.load("coco", Path(data_dir) / "real2d")
    groups = people.group[real2d.split(people) == "val"]
    images = {int(g.split("/")[1]) for g in groups}
    anns = sorted((a for a in anns if a["image_id"] in images), key=lambda a: a["id"])
    return {
        "info": {"description": ATTRIBUTION, "year": 2017,
                 "url": "https://cocodataset.org"},
        "licenses": [{"id": 1, "name": "Attribution 4.0 International (CC BY 4.0)",
                      "url": "https://creativecommons.org/licenses/by/4.0/"}],
        "images": [{k: im[k] for k in ("id", "file_name", "width", "height")}
                   for im in _unique(doc["images"]) if im["id"] in images],
        "annotations": [{k: a[k] for k in KEEP if k in a} for a in anns],
        "categories": [c for c in doc["categories"] if c.get("name") == "person"],
    }


def _unique(images):
    """`images` sorted by id, each id once (the source lists an image once per person)."""
    return sorted({im["id"]: im for im in images}.values(), key=lambda im: im["id"])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default=str(ROOT.parent / "shared" / "data"))
    args = ap.parse_args(argv)
    doc = example(args.data_dir)
    OUTPUT.write_text(json.dumps(doc, separators=(",", ":")) + "\n", encoding="utf-8")
    kp = np.array([a["keypoints"] for a in doc["annotations"]]).reshape(-1, 17, 3)
    print(f"wrote {OUTPUT.name}: {len(doc['images'])} images, "
          f"{len(kp)} people, {int((kp[..., 2] > 0).all(axis=1).sum())} with all 17 keypoints")


if __name__ == "__main__":
    main()
