"""``python -m benchmarks [--quick] [--write-docs]``: run the fit, recovery,
adaptation and lifting-speed benchmarks in one process and print their tables.

Only with ``--write-docs`` are the tracked files rewritten: the tables in
benchmarks/README.md between the markers (the full run's RESULTS block,
``--quick``'s QUICK block) and the raw numbers in benchmarks/results[-quick].json.
``--quick`` (k = 200, a few hundred poses) is a smoke test, not a measurement:
0.3 min with the CMU set already cached, 218 s on a fresh machine (with
the CMU set built first, 2 shared cores).
The CMU training set it builds is cached in the user's cache directory
(:func:`benchmarks.cache_dir`).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from sparseedm._atomic import save_json

from . import (adaptation, alphas, lifting, loadavg, log, machine, recovery, versions,
               write_block)

HERE = Path(__file__).resolve().parent
README = HERE / "README.md"


def goals(fit_res, rec_res, adapt_res=None, lift_res=None):
    """Each goal: (text, met?, evidence)."""
    out = []
    rows = {r["name"]: r for r in fit_res["rows"]}
    spams = next((r for n, r in rows.items() if n.startswith("SPAMS")), None)
    if spams is None or "error" in spams:
        out.append(("fit: time <= SPAMS trainDL at equal or better held-out error", None,
                    f"SPAMS not measured ({spams and spams.get('error')})"))
    else:
        mine = [r for r in fit_res["rows"] if r["name"].startswith("sparseedm") and "error" not in r]
        met = any(r["seconds"] <= spams["seconds"] and r["err_ave"] <= spams["err_ave"]
                  for r in mine)
        out.append(("fit: time <= SPAMS trainDL at equal or better held-out error", met,
                    "; ".join(f"{r['name'].replace('sparseedm OnlineDictionaryLearning', 'ours')}"
                              f" {r['seconds']:.1f} s, Err_ave {r['err_ave']:.3f}%" for r in mine)
                    + f" vs SPAMS {spams['seconds']:.1f} s, Err_ave {spams['err_ave']:.3f}%"))
    mix = rec_res["protocols"]["Mix (1-3 missing)"]["rows"]
    clar = mix["recover(solver='clarabel', n_jobs=2)"]
    out.append(("recovery: Clarabel path >= 150 poses/s, certified (Mix)",
                clar["pps"] >= 150 and clar["certified"] == 1.0,
                f"{clar['pps']:.0f} poses/s, certified {100 * clar['certified']:.2f}%"))
    f1 = mix["recover(solver='fast', n_jobs=1)"]
    f2 = mix["recover(solver='fast', n_jobs=2)"]
    best = max(f1["pps"], f2["pps"])
    sp = [r["pps"] for n, r in mix.items() if n.startswith("lasso only: SPAMS") and "pps" in r]
    cert = min(f1["certified"], f2["certified"])
    oc = rec_res["objective_check"]
    if sp:
        met = (best >= 3 * max(sp) and cert == 1.0 and oc["max_rel_diff"] <= 1e-6)
        out.append(("recovery: fast path >= 3x SPAMS lasso (2 threads) end to end, all "
                    "certified, objectives within 1e-6 of Clarabel's on a checked sample "
                    "(Mix)", met,
                    f"fast recover {best:.0f} poses/s end to end (lasso only "
                    f"{mix['lasso only: sparseedm FastSolver (numba, 2 threads)']['pps']:.0f}) vs "
                    f"SPAMS lasso-only {max(sp):.0f} poses/s = {best / max(sp):.2f}x; certified "
                    f"{100 * cert:.2f}%, fallbacks {f1['fallbacks']} / {f2['fallbacks']}; "
                    f"max relative objective difference to Clarabel {oc['max_rel_diff']:.1e} "
                    f"on {oc['n']} sub-problems"))
    one = mix.get(recovery.ONE_CORE, {}).get("pps")
    if one:
        out.append(("recovery: near-linear in cores, best 2-core rate >= 1.8x one core (Mix)",
                    best >= 1.8 * one,
                    f"{best:.0f} vs {one:.0f} poses/s = {best / one:.2f}x"))
    if adapt_res is not None:
        first = next(iter(adapt_res["rows"].values()))
        out.append((f"adaptation on {adapt_res['n_poses']:,} complete poses <= "
                    f"{adaptation.GOAL_SECONDS:.0f} s on 2 cores",
                    first["seconds"] <= adaptation.GOAL_SECONDS, f"{first['seconds']:.1f} s"))
    if lift_res is not None:
        met, ev = lifting.speed_goal(lift_res)
        out.append((f"lifting >= {lifting.LIFT_GOAL:.0f} poses/s on 2 cores, complete and Mix",
                    met, ev))
    return out


def render(fit_res, rec_res, meta, quick, adapt_res=None, lift_res=None):
    from . import fit

    lines = []
    lines.append(f"Run: {meta['date']}, `python -m benchmarks{' --quick' if quick else ''}`, "
                 f"{meta['minutes']:.1f} min in all.")
    m = meta["machine"]
    lines.append(f"Machine: {m['cpu']}, {m['cores']} cores, {m['ram']} RAM, Python "
                 f"{m['python']} ({m['platform']}).")
    lines.append("Versions: " + ", ".join(f"{k} {v}" for k, v in meta["versions"].items()) + ".")
    la0, la1 = meta["loadavg_start"], meta["loadavg_end"]
    lines.append(f"Load average (1/5/15 min) at start {la0}, at end {la1}"
                 + (" -- the machine was shared with other jobs during the run, so all "
                    "times are pessimistic and noisy (2 cores)." if la0 and max(la0[0], la1[0]) > 1.5
                    else "."))
    lines.append(f"OMP_WAIT_POLICY={meta['omp_wait_policy']} (set by the benchmark; see below).")
    lines.append("")
    lines.append("### Goals")
    lines.append("")
    for text, met, ev in goals(fit_res, rec_res, adapt_res, lift_res):
        mark = "not measured" if met is None else ("**met**" if met else "**NOT met**")
        lines.append(f"- {text}: {mark} ({ev})")
    lines.append("")
    lines.append("### Dictionary learning (benchmarks/fit.py)")
    lines.append("")
    lines.append(fit.render(fit_res))
    lines.append("")
    lines.append("### Recovery speed (benchmarks/recovery.py)")
    lines.append("")
    lines.append(recovery.render(rec_res))
    if adapt_res is not None:
        lines += ["", "### Adaptation (benchmarks/adaptation.py)", "",
                  adaptation.render_rows(adapt_res)]
    if lift_res is not None:
        lines += ["", "### Lifting speed (benchmarks/lifting.py)", "",
                  lifting.render_speed(lift_res)]
    return "\n".join(lines)


def main(argv=None):
    import os

    import numpy as np

    from . import fit, recovery

    ap = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="tiny settings, a smoke test (0.3 min with the CMU set cached; "
                    "218 s measured on a fresh 2-core machine, building it first)")
    ap.add_argument("--write-docs", action="store_true",
                    help="also rewrite benchmarks/README.md's tables and "
                    "benchmarks/results[-quick].json (tracked files); default: print only")
    args = ap.parse_args(argv)
    t0 = time.time()
    meta = dict(date=time.strftime("%Y-%m-%d %H:%M %Z"), machine=machine(), versions=versions(),
                loadavg_start=loadavg(), omp_wait_policy=os.environ.get("OMP_WAIT_POLICY"),
                alphas=alphas())
    log(f"benchmarks: start, load average {meta['loadavg_start']}")
    fit_res = fit.run(args.quick)
    comps = fit_res.pop("components")
    rec_res = recovery.run(args.quick, components=comps)
    log("adaptation")
    adapt_res = adaptation.run(args.quick)
    log("lifting speed")
    lift_res = lifting.run_speed(args.quick)
    meta["loadavg_end"] = loadavg()
    meta["minutes"] = (time.time() - t0) / 60
    text = render(fit_res, rec_res, meta, args.quick, adapt_res, lift_res)
    print(text)
    if args.write_docs:
        write_block("QUICK" if args.quick else "RESULTS",
                    "Quick smoke test" if args.quick else "Results", text, README)
        raw = HERE / ("results-quick.json" if args.quick else "results.json")
        save_json(raw, dict(meta=meta, fit=fit_res, recovery=rec_res, adaptation=adapt_res,
                            lifting_speed=lift_res), indent=1, default=str)
        log(f"benchmarks: wrote {README} and {raw.name}")


if __name__ == "__main__":
    main()
