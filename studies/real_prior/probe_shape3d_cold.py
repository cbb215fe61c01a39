"""The shape-model fill (``probe_shape3d.py``) stacked with ``recover(adapt=False)``,
its weight chosen per file without the truth: on probes of the file's occluded
rows (:func:`sparseedm.donors.probes`: up to 300 rows, one more observed joint
hidden), answered by the cold path and by the shape model, the weight of
``probe_shape3d.WEIGHTS`` with the lowest probed error, kept when its gain over
the cold answer exceeds ``exemplars.LINEAR_MIN_SE`` standard errors (else 0),
as :func:`sparseedm.exemplars.probe_stack` chooses the Gaussian's. Only the
shape models that use nothing of the file: ``raw`` (CMU) and ``coco`` (mean
moved on COCO's training people). Gain on the file's occluded poses [mean,
paired standard error], positive: lower error.

    python studies/real_prior/probe_shape3d_cold.py --files mpii,bonn --seeds 0,1,2 \\
        --out results_shape3d_cold.json
    python studies/real_prior/probe_shape3d_cold.py --table results_shape3d_cold.json

``--table``: per file and masks, the cold error (mean over seeds), the weights
chosen and the gains pooled over seeds (mean, standard error from the seeds').
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from sparseedm._atomic import json_text  # noqa: E402
import sparseedm  # noqa: E402
from benchmarks import real2d  # noqa: E402
import harness  # noqa: E402
from probe_shape3d import POSES, WEIGHTS, add_model_args, gain_se, per_pose  # noqa: E402
from shape3d_answers import CACHE, answers  # noqa: E402
from shape3d_model import build_model, calibrate, shape_fill  # noqa: E402
from sparseedm.donors import probes  # noqa: E402
from sparseedm.exemplars import LINEAR_MIN_SE, paired_gain  # noqa: E402


def probe_weight(cold, fill, truth, pmiss, rows, joints):
    """The weight chosen on the probes (their probed joints' errors)."""
    size = real2d.body_size(truth[rows])
    at = np.arange(len(rows)), joints
    errs = np.array([np.linalg.norm(((1 - w) * cold + w * fill)[at] - truth[rows][at], axis=-1)
                     / size * 100 for w in WEIGHTS])
    best = int(np.argmin(errs.mean(axis=1)))
    mean, se = paired_gain(errs[0] - errs[best])
    return float(WEIGHTS[best]) if mean > LINEAR_MIN_SE * se else 0.0


def table(path):
    """Markdown rows of the JSON at `path` (see the module docstring)."""
    from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN
    lines = ["| file | masks | cold | cold+raw: w / gain | cold+coco: w / gain |",
             "|---|---|---|---|---|"]
    for name, protos in load_results(path)["files"].items():
        for proto, seeds in protos.items():
            rows = list(seeds.values())
            cells = [name, proto, f"{np.mean([r['cold'] for r in rows]):.2f}"]
            for k in ("cold+raw", "cold+coco"):
                g = np.array([r[k]["gain"] for r in rows])
                se = np.sqrt((g[:, 1] ** 2).sum()) / len(g)
                ws = ", ".join(f"{r[k]['w']:.1f}" for r in rows)
                cells.append(f"{ws} / {g[:, 0].mean():+.2f} ± {se:.2f} "
                             f"(worst seed {g[:, 0].min():+.2f})")
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--table", type=Path, help="print the table of this JSON")
    ap.add_argument("--files", default="mpii,bonn")
    ap.add_argument("--protocols", default=",".join(harness.PROTOCOLS))
    add_model_args(ap)
    a = ap.parse_args(argv)
    if a.table:
        print(table(a.table))
        return
    model = build_model(np.load(POSES), a.k)
    coco = real2d.load("coco")
    models = {"raw": model, "coco": calibrate(model, coco.poses[
        coco.complete & (real2d.split(coco) == "train") & (real2d.body_size(coco.poses) > 0)],
        noise=a.noise)}
    kw = dict(noise=a.noise, temperature=a.temperature)
    out = {"settings": {"k": a.k, "noise": a.noise, "temperature": a.temperature,
                        "weights": WEIGHTS.tolist()}, "files": {}}
    for name in a.files.split(","):
        rs = real2d.load(harness.FILES[name][0])
        for protocol in a.protocols.split(","):
            for seed in map(int, a.seeds.split(",")):
                truth, missing, got = answers(name, protocol, seed, rs, methods=("cold",))
                rows, joints = probes(missing, seed)
                pmiss = missing[rows].copy()
                pmiss[np.arange(len(rows)), joints] = True
                pposes = np.where(pmiss[..., None], np.nan, truth[rows])
                path = CACHE / f"{name}_{protocol}_{seed}_probes.npz"
                if path.exists():
                    pcold = np.load(path)["cold"]
                else:
                    pcold = sparseedm.recover(pposes, pmiss, adapt=False).poses
                    np.savez(path, cold=pcold)
                given = np.where(missing[..., None], np.nan, truth)
                row = {"cold": round(harness.score(got["cold"], truth, missing), 3),
                       "probes": int(len(rows))}
                base = per_pose(got["cold"], truth, missing)
                for k, m in models.items():
                    w = probe_weight(pcold, shape_fill(m, pposes, pmiss, **kw), truth, pmiss,
                                     rows, joints)
                    fill = shape_fill(m, given, missing, **kw)
                    stacked = per_pose((1 - w) * got["cold"] + w * fill, truth, missing)
                    row[f"cold+{k}"] = {"w": w, "gain": gain_se(base - stacked)}
                out["files"].setdefault(name, {}).setdefault(protocol, {})[str(seed)] = row
                print(name, protocol, seed, json.dumps(row), flush=True)
    if a.out:
        a.out.write_text(json_text(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
