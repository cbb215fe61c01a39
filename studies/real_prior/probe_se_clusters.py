"""probe_stack's gain test with the probes of one pose as one cluster, against
every probe counted as independent: which weights change, and what that does.

:func:`sparseedm.exemplars.probe_stack` (files with fewer than
:data:`~sparseedm.exemplars.FEW_MIN_POSES` complete poses) probes the occluded
rows in rounds, a row again in each (another joint), until
:data:`~sparseedm.donors.DONOR_PROBES` probes. Its weight is kept when the gain
over weight 0 exceeds :data:`~sparseedm.exemplars.LINEAR_MIN_SE` standard
errors: ``clustered`` (what ships) averages each row's probes first and takes
the standard error over rows (:func:`sparseedm.exemplars.paired_gain` with
``clusters``); ``independent`` (before) over the probes.

Files (``harness.make_file``, validation splits): MPII val and Bonn val frames
at 28 and 40 complete + 200 occluded poses, the COCO val file whole (27 + 28);
protocols 2 random hidden joints and ``real`` (transplanted masks). One
``recover()`` per file records the probes' gains and both rules' decisions;
where they differ the file is recovered again under the other rule. Score: per
occluded pose the mean error of its hidden joints, % of body size;
``clustered - independent`` paired [mean, standard error].

    python studies/real_prior/probe_se_clusters.py --seeds 0,1,2
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
sys.path.insert(0, str(HERE))
from sparseedm._atomic import json_text  # noqa: E402

import harness  # noqa: E402

FILES = [("mpii", (28, 200)), ("mpii", (40, 200)), ("bonn", (28, 200)), ("bonn", (40, 200)),
         ("coco-val", None)]


@contextlib.contextmanager
def rule(independent, seen):
    """paired_gain as shipped (`independent`: clusters ignored), calls noted in `seen`."""
    import sparseedm.exemplars as ex

    real = ex.paired_gain

    def spy(gain, clusters=None):
        seen.append({"independent": real(gain), "clustered": real(gain, clusters),
                     "probes": int(len(gain)),
                     "rows": None if clusters is None else int(len(np.unique(clusters)))})
        return real(gain, None if independent else clusters)

    ex.paired_gain = spy
    try:
        yield
    finally:
        ex.paired_gain = real


def per_pose(filled, truth, missing):
    size = harness.real2d.body_size(truth)
    err = np.linalg.norm(filled - truth, axis=-1) / size[:, None] * 100
    occ = missing.any(axis=1)
    return np.nanmean(np.where(missing, err, np.nan)[occ], axis=1)


def recover(truth, missing, independent):
    import sparseedm

    seen = []
    with rule(independent, seen):
        res = sparseedm.recover(np.where(missing[..., None], np.nan, truth), missing)
    return res, seen


def measure(truth, missing):
    from sparseedm.exemplars import LINEAR_MIN_SE

    res, seen = recover(truth, missing, independent=False)
    out = {"weight": {"clustered": res.adaptation.settings.get("linear_weight")}}
    if not seen:
        return out
    kept = {k: bool(seen[0][k][0] > LINEAR_MIN_SE * seen[0][k][1])
            for k in ("independent", "clustered")}
    out.update(probes=seen[0]["probes"], rows=seen[0]["rows"], kept=kept,
               gain={k: [round(v, 4) for v in seen[0][k]] for k in kept})
    errors = {"clustered": per_pose(res.poses, truth, missing)}
    if kept["independent"] == kept["clustered"]:
        out["weight"]["independent"] = out["weight"]["clustered"]
        errors["independent"] = errors["clustered"]
    else:
        other, _ = recover(truth, missing, independent=True)
        out["weight"]["independent"] = other.adaptation.settings.get("linear_weight")
        errors["independent"] = per_pose(other.poses, truth, missing)
    d = errors["clustered"] - errors["independent"]
    out["error"] = {k: round(float(np.mean(e)), 4) for k, e in errors.items()}
    out["clustered_minus_independent"] = [round(float(d.mean()), 4),
                                          round(float(d.std(ddof=1) / np.sqrt(len(d))), 4)]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--protocols", default="2,real")
    ap.add_argument("--out", type=Path, default=HERE / "results_probe_se_clusters.json")
    a = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    doc = json.loads(a.out.read_text()) if a.out.exists() else {"files": {}}
    sets = {}
    for seed in (int(s) for s in a.seeds.split(",")):
        for name, sizes in FILES:
            source = harness.FILES[name][0]
            rs = sets.setdefault(source, harness.real2d.load(source))
            for protocol in a.protocols.split(","):
                key = f"{name} {sizes or ''} protocol {protocol} seed {seed}"
                if key in doc["files"]:
                    continue
                truth, missing = harness.make_file(name, protocol, seed, sizes, rs)
                doc["files"][key] = measure(truth, missing)
                print(key, doc["files"][key], flush=True)
                a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
