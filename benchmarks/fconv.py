"""FConv (sparseedm.fconv, torch extra): training time, CPU inference speed beside the
sparse path, and the paper's Table 1 experiment with the 2D -> 3D network.

    python -m benchmarks.fconv [--quick] [--cross DATASET.npz] [--write-docs]

* **Training**: :func:`sparseedm.fconv.fit_fconv` (defaults: 'average', channels
  (32, 64), batch 256, Adam 1e-3, at most ``--epochs`` epochs, patience 4) on the
  CMU training clips (the held-out clips of :func:`benchmarks.split_clips` are
  never seen; the fit's own validation split is by clip inside the rest), one
  torch thread. Wall and CPU seconds.
* **Inference**: Mix-occluded held-out poses; the network alone
  (``FConvModel.predict``) and end to end (``recover(method="fconv")``:
  represent, network, Eq. 10 merge, joint placement) at batch 4,096 and batch 1,
  with 1 and 2 torch threads; beside ``recover(solver="fast")`` with the shipped
  k = 2000 dictionary on the same poses (numba on 1 and 2 threads). Poses/s from
  wall time, best of 3; the machine is shared, so compare rows of one run.
* **Table 1** (DMR's 2D -> 3D regression, as Guo & Dai's Table 1 uses it):
  :func:`sparseedm.fconv.fit_edm_lifter` trained on complete 2D inputs, then
  retrained with 1-3 occluded joints per pose ('average'), both tested on the
  held-out CMU clips (and on ``--cross`` poses) with 0, 1, 2, 3 occluded joints;
  Err_ave (per cent) of the predicted 3D EDM against the true one (metres).

The text goes between ``<!-- BEGIN FCONV -->`` and ``<!-- END FCONV -->`` in
benchmarks/README.md; raw numbers to benchmarks/results-fconv.json.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from . import held_out_sample, loadavg, log, machine, split_clips, table, write_block
from sparseedm._atomic import save_json

HERE = Path(__file__).resolve().parent
FULL = dict(epochs=20, max_train=None, lift_max_train=10000, n=4096, n_single=300, n_sparse=2000, n_sparse_single=100,
            n_table=2000, lift_epochs=20)
QUICK = dict(epochs=2, max_train=2000, lift_max_train=2000, n=4096, n_single=50, n_sparse=200, n_sparse_single=20,
             n_table=300, lift_epochs=2)


def _dataset():
    from . import load_cmu

    _, _, path = load_cmu()
    with np.load(path, allow_pickle=False) as d:
        return d["poses2d"], d["poses3d"], d["clips"], path


def _best(fn, repeats=3):
    """(wall, CPU) seconds of the fastest of `repeats` calls (CPU: all threads summed)."""
    best = (np.inf, np.inf)
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        best = min(best, (time.perf_counter() - t0, time.process_time() - c0))
    return best


def _rate(n, t):
    return [n / t[0], n / t[1]]


def train(p2, clips, cfg, **kw):
    import torch

    from sparseedm.fconv import fit_fconv

    torch.set_num_threads(1)
    w0, c0 = time.perf_counter(), time.process_time()
    model = fit_fconv(p2, clips, max_epochs=cfg["epochs"], max_train=cfg["max_train"], **kw)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    t = model.meta["training"]
    return model, dict(seconds=wall, cpu_seconds=cpu, epochs=t["epochs"], n_train=t["n_train"],
                       n_val=t["n_val"], best_val_loss=t["best_val_loss"],
                       s_per_epoch=wall / t["epochs"], threads=1, **{k: str(v) for k, v in kw.items()})


def speed(model, poses, mask, cfg):
    import numba
    import torch

    from sparseedm.dictionary import load_dictionary
    from sparseedm.normalize import represent
    from sparseedm.recovery import recover

    inputs = np.where(mask[..., None], np.nan, poses)
    X = represent(poses, mask, model.representation)[0]
    rows = {}
    ns = cfg["n_single"]
    for threads in (1, 2):
        torch.set_num_threads(threads)
        model.predict(X[:8])
        rec = lambda sl: recover(inputs[sl], mask[sl], method="fconv", model=model,  # noqa: E731
                                 representation=model.representation)
        t = _best(lambda: model.predict(X))
        rows[f"FConv network only, batch {len(X)}, {threads} thread(s)"] = _rate(len(X), t)
        t = _best(lambda: [model.predict(X[i:i + 1]) for i in range(ns)])
        rows[f"FConv network only, batch 1, {threads} thread(s)"] = _rate(ns, t)
        t = _best(lambda: rec(slice(None)))
        rows[f"recover(method='fconv'), batch {len(X)}, {threads} thread(s)"] = _rate(len(X), t)
        t = _best(lambda: [rec(slice(i, i + 1)) for i in range(ns)])
        rows[f"recover(method='fconv'), batch 1, {threads} thread(s)"] = _rate(ns, t)
    d = load_dictionary("default")
    n, n1 = cfg["n_sparse"], cfg["n_sparse_single"]
    recover(inputs[:64], mask[:64], dictionary=d)  # numba compile and caches out of the timing
    for threads in (1, 2):
        numba.set_num_threads(threads)
        t = _best(lambda: recover(inputs[:n], mask[:n], dictionary=d), 2)
        rows[f"recover(solver='fast') k=2000, batch {n}, numba {threads} thread(s)"] = _rate(n, t)
        t = _best(lambda: [recover(inputs[i:i + 1], mask[i:i + 1], dictionary=d)
                           for i in range(n1)], 2)
        rows[f"recover(solver='fast') k=2000, batch 1, numba {threads} thread(s)"] = _rate(n1, t)
    return rows


def table1(p2, p3, clips, tests, cfg):
    """Err_ave of lifted 3D EDMs: trained complete vs retrained occluded, 0-3 missing."""
    import torch

    from sparseedm.edm import pose_to_vector
    from sparseedm.fconv import fit_edm_lifter, lift_edm_vectors
    from sparseedm.metrics import err_ave, random_occlusion

    torch.set_num_threads(1)
    out = []
    for name, occluded in (("trained on complete input", (0, 0)),
                           ("retrained on occluded input (1-3)", (1, 3))):
        t0 = time.perf_counter()
        model = fit_edm_lifter(p2, p3, clips, occluded=occluded, max_epochs=cfg["lift_epochs"],
                               max_train=cfg["lift_max_train"], representation="average")
        secs = time.perf_counter() - t0
        for test, (t2, t3) in tests.items():
            gt = pose_to_vector(t3)
            for k in (0, 1, 2, 3):
                mask = random_occlusion(len(t2), t2.shape[1], k, random_state=k)
                e = err_ave(lift_edm_vectors(model, np.where(mask[..., None], np.nan, t2)), gt)
                out.append(dict(network=name, test=test, missing=k, err_ave=float(np.mean(e)),
                                err_var=float(np.var(e)), epochs=model.meta["training"]["epochs"],
                                fit_seconds=secs))
    return out


def render(res):
    m = res["machine"]
    lines = [f"Run: {res['date']}, `python -m benchmarks.fconv{' --quick' if res['quick'] else ''}`"
             f", {res['minutes']:.1f} min. Machine: {m['cpu']}, {m['cores']} cores, shared "
             f"(load average {res['loadavg_start']} at start, {res['loadavg_end']} at end); "
             f"torch {res['torch']}.", ""]
    tr = res["training"]
    lines += ["**Training** (`fit_fconv`, 'average', channels (32, 64), batch 256, 1 torch "
              "thread):", "",
              table(["poses", "validation poses", "epochs", "wall s", "CPU s", "wall s / epoch",
                     "best val. loss"],
                    [[tr["n_train"], tr["n_val"], tr["epochs"], tr["seconds"], tr["cpu_seconds"],
                      tr["s_per_epoch"], tr["best_val_loss"]]]), ""]
    lines += [f"**Inference** on {res['n']} held-out CMU poses, Mix occlusion, best of 3. "
              "Wall time suffers from the other jobs on the 2 shared cores; poses per "
              "CPU-second (process time, all threads summed) is what one unshared core "
              "would do:", "", table(["what", "poses/s (wall)", "poses per CPU-second"],
                         [[k, *v] for k, v in res["speed"].items()]),
              ""]
    nan = [float("nan")] * 2
    net = res["speed"].get(f"FConv network only, batch {res['n']}, 1 thread(s)", nan)
    e2e = res["speed"].get(f"recover(method='fconv'), batch {res['n']}, 1 thread(s)", nan)
    lines += [f"Goal >= 20,000 poses/s at batch 4,096 on CPU, one thread: network "
              f"{net[1]:,.0f} poses per CPU-second ({net[0]:,.0f} wall), end to end "
              f"{e2e[1]:,.0f} ({e2e[0]:,.0f} wall) -- network "
              + ("**met**" if net[1] >= 20000 else "**NOT met**") + ", end to end "
              + ("**met**" if e2e[1] >= 20000 else "**NOT met**") + ".", ""]
    if res.get("table1"):
        tests = list(dict.fromkeys(r["test"] for r in res["table1"]))
        rows = []
        for net in dict.fromkeys(r["network"] for r in res["table1"]):
            for test in tests:
                rs = [r for r in res["table1"] if r["network"] == net and r["test"] == test]
                rows.append([net, test] + [r["err_ave"] for r in sorted(rs, key=lambda r:
                                                                        r["missing"])])
        lines += ["**Table 1** (2D -> 3D EDM network, 'average' input; Err_ave % of the 3D EDM; "
                  "paper: 9.27 complete, 21-24 occluded, ~17.2 retrained):", "",
                  table(["network", "test poses", "0 missing", "1", "2", "3"], rows)]
    return "\n".join(lines)


def main(argv=None):
    import torch

    ap = argparse.ArgumentParser(prog="python -m benchmarks.fconv",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="tiny settings: a smoke test")
    ap.add_argument("--cross", default=None, help="another source's dataset .npz (poses2d, "
                    "poses3d) for the Table 1 test, e.g. a Bandai-Namco build")
    ap.add_argument("--no-table1", action="store_true", help="skip the 2D -> 3D experiment")
    ap.add_argument("--write-docs", action="store_true", help="also rewrite its block of benchmarks/README.md and its results JSON (tracked files); default: print only")
    args = ap.parse_args(argv)
    cfg = QUICK if args.quick else FULL
    t0 = time.time()
    res = dict(date=time.strftime("%Y-%m-%d %H:%M %Z"), machine=machine(),
               loadavg_start=loadavg(), quick=args.quick, torch=torch.__version__, cfg=cfg)
    p2, p3, clips, path = _dataset()
    held, _ = split_clips(clips)
    log(f"fconv: training on {int((~held).sum())} poses of the CMU training clips")
    model, res["training"] = train(p2[~held], clips[~held], cfg)
    test = held_out_sample(p2[held], cfg["n"], seed=2)
    from sparseedm.metrics import random_occlusion

    mask = random_occlusion(len(test), test.shape[1], "mix", random_state=0)
    res["n"] = len(test)
    log("fconv: inference speed")
    res["speed"] = speed(model, test, mask, cfg)
    if not args.no_table1:
        rng = np.random.default_rng(4)
        pick = np.sort(rng.choice(int(held.sum()), min(cfg["n_table"], int(held.sum())),
                                  replace=False))
        tests = {"CMU held-out clips": (p2[held][pick], p3[held][pick])}
        if args.cross:
            with np.load(args.cross, allow_pickle=False) as d:
                c2, c3 = d["poses2d"], d["poses3d"]
            pick = np.sort(np.random.default_rng(5).choice(len(c2), min(cfg["n_table"], len(c2)),
                                                           replace=False))
            tests[Path(args.cross).stem] = (c2[pick], c3[pick])
        log("fconv: Table 1 (2D -> 3D)")
        res["table1"] = table1(p2[~held], p3[~held], clips[~held], tests, cfg)
    res["loadavg_end"] = loadavg()
    res["minutes"] = (time.time() - t0) / 60
    text = render(res)
    print(text)
    if args.write_docs:
        write_block("FCONV", "FConv (torch extra)", text)
        save_json(HERE / ("results-fconv-quick.json" if args.quick else "results-fconv.json"),
                  res, indent=1, default=str)


if __name__ == "__main__":
    main()
