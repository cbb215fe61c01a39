"""Speed and accuracy of sparseedm against its peers, measured in one run.

``python -m benchmarks [--quick]`` runs :mod:`benchmarks.fit` (dictionary
learning: ours vs SPAMS ``trainDL`` vs scikit-learn) and
:mod:`benchmarks.recovery` (lasso recovery: our fast and Clarabel paths vs
SPAMS ``lasso``, scikit-learn ``sparse_encode``, naive cvxpy) and prints the
tables; with ``--write-docs`` it also rewrites them in ``benchmarks/README.md``.

This module holds what both share: the CMU data and its by-clip split, the
alphas, machine and version facts, and table formatting.
"""

from __future__ import annotations

import os

# OpenMP threads that spin-wait collapse when the 2 cores are shared with other
# work (measured: SPAMS trainDL with numThreads=2 ran 40x slower than with 1
# under a load average of 4); passive waiting removes that for every OpenMP
# user here (SPAMS' libgomp and numba's omp layer alike). Set before either loads.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import argparse
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from sparseedm._atomic import save_json

ROOT = Path(__file__).resolve().parent.parent
CMU_RAW = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cmu-mocap"


def cache_dir() -> Path:
    """The user's cache folder for sparseedm: ``$XDG_CACHE_HOME/sparseedm``, else
    ``~/.cache/sparseedm`` (not a fixed temporary path others can write)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sparseedm"


#: where the benchmarks' CMU training set is built once (same command, same seed)
CMU_CACHE = "benchmarks-cmu_train.npz"
SELECTION = ROOT / "studies" / "dictionary" / "selection.json"
SHIPPED_K2000 = ROOT / "dictionaries" / "cmu-k2000.npz"
DEFAULT_ALPHA_TRAIN = 0.2
DEFAULT_ALPHA_RECOVER = 0.0005


def log(*args):
    print(f"[{time.strftime('%H:%M:%S')}]", *args, file=sys.stderr, flush=True)


def built_set(raw, cache_name, what, seconds="about 20 s"):
    """The dataset .npz of the mocap folder `raw` (``sparseedm dataset build raw
    --seed 0``), built once into :func:`cache_dir` as `cache_name`; its path."""
    p = cache_dir() / cache_name
    if not p.is_file():
        p.parent.mkdir(parents=True, exist_ok=True)
        log(f"building the {what} into {p} ({seconds})")
        subprocess.run([sys.executable, "-m", "sparseedm", "dataset", "build", str(raw),
                        "-o", str(p), "--seed", "0", "--quiet"], check=True)
    return p


def load_cmu():
    """(poses2d, clips, path) of the CMU training set; built once if absent.

    The set is ``sparseedm dataset build /work/shared/data/cmu-mocap --seed 0``.
    """
    p = built_set(CMU_RAW, CMU_CACHE, "CMU training set")
    with np.load(p, allow_pickle=False) as npz:
        return npz["poses2d"], npz["clips"], p


def run_line(meta, command):
    """The first line of a benchmark's block: when, which command, the machine and
    its load (a loaded shared machine is said to give pessimistic, noisy times)."""
    m = meta["machine"]
    return (f"Run: {meta['date']}, `{command}{' --quick' if meta['quick'] else ''}`; "
            f"machine: {m['cpu']}, {m['cores']} cores; load average at start "
            f"{meta['loadavg_start']}, at end {meta['loadavg_end']}"
            + (" (shared machine: times are pessimistic and noisy)."
               if meta["loadavg_start"] and meta["loadavg_start"][0] > 1.5 else "."))


def bench_main(argv, *, prog, doc, quick_help, run, render, tag, heading, results):
    """A benchmark's command line: ``--quick`` (printed only) and ``--write-docs``
    (its block `tag` of benchmarks/README.md under `heading`, and the raw numbers
    in `results`, a JSON file beside it)."""
    ap = argparse.ArgumentParser(prog=prog, description=doc.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=quick_help)
    ap.add_argument("--write-docs", action="store_true",
                    help="also rewrite its block of benchmarks/README.md and its results "
                    "JSON (tracked files); default: print only")
    args = ap.parse_args(argv)
    meta = dict(date=time.strftime("%Y-%m-%d %H:%M %Z"), machine=machine(),
                versions=versions(), loadavg_start=loadavg(), quick=args.quick)
    res = run(args.quick)
    meta["loadavg_end"] = loadavg()
    text = render(res, meta)
    print(text)
    if args.write_docs and not args.quick:
        write_block(tag, heading, text)
        save_json(Path(__file__).resolve().parent / results, dict(meta=meta, **res),
                  indent=1, default=str)


def split_clips(clips):
    """Held-out mask: every 5th clip in sorted order, starting at the 3rd.

    The same split as ``studies/dictionary/select_alpha.py`` (by clip, never by frame).
    """
    names = sorted(set(clips.tolist()))
    held = sorted(c for i, c in enumerate(names) if i % 5 == 2)
    return np.isin(clips, held), held


def held_out_sample(poses, n, seed=0):
    """n held-out poses drawn as select_alpha.py draws its validation poses."""
    rng = np.random.default_rng(seed)
    return poses[np.sort(rng.choice(len(poses), min(n, len(poses)), replace=False))]


def alphas():
    """(alpha_train, alpha_recover, source) from studies/dictionary/selection.json 'best'."""
    if SELECTION.is_file():
        try:
            best = json.loads(SELECTION.read_text())["best"]
            return float(best["alpha_train"]), float(best["alpha_recover"]), str(SELECTION.relative_to(ROOT))
        except (KeyError, ValueError, TypeError):
            pass
    return DEFAULT_ALPHA_TRAIN, DEFAULT_ALPHA_RECOVER, "defaults (studies/dictionary/selection.json absent)"


def machine():
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    ram = "unknown"
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                ram = f"{int(line.split()[1]) / 1024 ** 2:.1f} GiB"
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "ram": ram,
            "python": platform.python_version(), "platform": platform.platform()}


def versions():
    out = {}
    for mod in ("numpy", "scipy", "sklearn", "cvxpy", "clarabel", "numba", "joblib", "sparseedm"):
        try:
            out[mod] = __import__(mod).__version__
        except Exception as exc:  # pragma: no cover - report, do not fail
            out[mod] = f"unavailable ({exc.__class__.__name__})"
    try:
        from importlib.metadata import version

        out["spams"] = version("spams-bin")
    except Exception:
        try:
            out["spams"] = version("spams")
        except Exception:
            out["spams"] = "unavailable"
    return out


def loadavg():
    try:
        return tuple(round(x, 2) for x in os.getloadavg())
    except OSError:  # pragma: no cover
        return None


def table(headers, rows):
    """A GitHub markdown table."""
    def fmt(v):
        if isinstance(v, float):
            if v != v:
                return "n/a"
            if abs(v) >= 100:
                return f"{v:,.0f}"
            if abs(v) >= 1:
                return f"{v:.2f}"
            return f"{v:.3g}"
        return str(v)

    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(fmt(v) for v in r) + " |" for r in rows]
    return "\n".join(lines)


def write_block(tag, heading, text, readme=None):
    """Put `text` between ``<!-- BEGIN tag -->`` and ``<!-- END tag -->`` of
    benchmarks/README.md (a new section `heading` at the end the first time),
    written atomically."""
    import re
    from pathlib import Path

    readme = Path(readme) if readme else Path(__file__).resolve().parent / "README.md"
    begin, end = f"<!-- BEGIN {tag} -->", f"<!-- END {tag} -->"
    doc = readme.read_text() if readme.is_file() else ""
    block = f"{begin}\n{text}\n{end}"
    if begin in doc and end in doc:
        doc = re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda _: block, doc,
                     flags=re.S)
    else:
        doc = doc.rstrip("\n") + f"\n\n## {heading}\n\n{block}\n"
    tmp = readme.with_suffix(".md.tmp")
    tmp.write_text(doc)
    tmp.replace(readme)
