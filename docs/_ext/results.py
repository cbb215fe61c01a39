"""Results pages rendered from the benchmarks' own JSON files at build time.

``.. benchmark-results:: PAGE`` renders, one section each, every file of
:data:`PATTERN` that :data:`PAGES` assigns to ``PAGE`` (the first pattern that
matches a file's name wins; a file no pattern names goes to ``accuracy``). A new
``benchmarks/results-*.json`` therefore appears on the next build with no change
here; :data:`TITLES` gives it a readable title.

The renderer knows three shapes and falls back to a generic one:

* the video protocols' ``runs`` (each with ``rows`` of ``method``, ``group``,
  ``error``): one table per run, a row per method and a column per group;
* the real-people files' ``results`` (per source, ``rows`` of ``method``,
  ``condition``, ``group``, ``mean``): one table per source and condition;
* the paper protocol's ``paper_protocol`` (per dictionary, the ``rows`` of
  ``sparseedm evaluate``'s ``results.csv`` and its ``sweep``): Err_ave by
  occlusion count per method and representation, and the sweep;
* anything else: scalars as a two-column table, a mapping of mappings as one
  table (a row per key), a list of mappings as one table (a row per item),
  nested up to three levels under small headings.
"""

from __future__ import annotations

import fnmatch
import json
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive

ROOT = Path(__file__).resolve().parents[2]
#: which files are results (relative to the repository root)
PATTERN = "benchmarks/results*.json"
#: page -> file name patterns, tried in this order; unmatched files go to "accuracy"
PAGES = {
    "speed": ["results-frontier.json", "results.json", "results-quick.json",
              "results-adaptation.json",
              "results-default-path.json", "results-dask-default.json",
              "results-temporal.json", "results-video-speed*.json",
              "results-lifting-speed.json", "results-fconv.json"],
    "accuracy": ["results-real-people*.json", "results-paper-protocol.json",
                 "results-video*.json", "results-lifting*.json"],
}
#: readable titles (a file without one is titled by its name)
TITLES = {
    "results.json": "Dictionary learning and recovery speed against peers (k = 2000)",
    "results-quick.json": "The same, quick smoke test (k = 200)",
    "results-adaptation.json": "Adaptation on 5,000 poses",
    "results-default-path.json": "recover() with its defaults against adapt=False",
    "results-dask-default.json": "recover() defaults on a Dask cluster, 1 and 2 workers",
    "results-frontier.json": "Accuracy against speed: every setting and every peer",
    "results-temporal.json": "The video path on a 10,000-frame file and on one 150-frame clip",
    "results-video-speed.json": "The video path by stage",
    "results-lifting-speed.json": "Lifting speed",
    "results-fconv.json": "FConv network speed and Table 1 (2D to 3D)",
    "results-lifting.json": "Lifting accuracy: dictionary lifter and MLP",
    "results-lifting-fconv.json": "The application table (lifters x recovery pipelines)",
    "results-video.json": "Video protocols, validation and test (per-frame and fillers)",
    "results-video-adapt-test.json": "Video protocols, held-out test, one clip adapting",
    "results-video-intervals-30.json": "Video protocols, 30 sequences per split",
    "results-video-intervals-all.json": "Video protocols, every sequence of each split",
    "results-video-noise-30.json": "Video protocols with 1 % keypoint jitter",
    "results-video-pca.json": "PCA gap filling: how many components (validation)",
    "results-video-rerun.json": "Video protocols, re-run with the placement guard",
    "results-video-temporal.json": "Video protocols: the temporal model",
    "results-video-test-30.json": "Video protocols, held-out test, 30 sequences",
    "results-video-test-30-relative.json": "Held-out test, 30 sequences, joints smoothed relative to their parents",
    "results-video-validation.json": "Video protocols, validation sequences",
    "results-video-validation-30.json": "Video protocols, validation, 30 sequences",
    "results-real-people-val.json": "Real people, validation split",
    "results-real-people-val-train-complete.json":
        "Real people, validation split, training poses added as complete poses",
    "results-video-kalman.json": "Video protocols: the Kalman smoother beside the splines",
    "results-video-kalman-noise.json":
        "Video protocols: the Kalman smoother beside the splines, 1 % keypoint jitter",
    "results-video-kalman-bonn.json":
        "The Kalman smoother's settings on Bonn PoseTrack validation clips",
    "results-paper-protocol.json":
        "The paper's protocol: held-out Bandai-Namco styles, 1-3 hidden joints and Mix",
}
META_KEYS = {"machine", "versions", "meta", "date", "loadavg_start", "loadavg_end",
             "load_average", "load_average_before", "load_average_after", "load_start",
             "load_end", "settings", "argv", "note", "what", "cfg"}
MAX_ROWS = 40
MAX_COLUMNS = 10
def clean(text):
    """A label or cell as text."""
    return str(text).strip()


def place(name):
    """(page, rank): the first pattern matching `name`, its position in its page's list."""
    for page, patterns in PAGES.items():
        for rank, pattern in enumerate(patterns):
            if fnmatch.fnmatch(name, pattern):
                return page, rank
    return "accuracy", len(PAGES["accuracy"])


def files_for(page):
    """The results files of `page`, in the order of its patterns, then by name."""
    found = [p for p in ROOT.glob(PATTERN) if place(p.name)[0] == page]
    return sorted(found, key=lambda p: (place(p.name)[1], p.name))


def known(value):
    """Whether `value` is a number: not ``null`` (what sparseedm's reports write
    where there is none) nor NaN (what older files hold there)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and value == value


def fmt(value):
    if isinstance(value, float) and value != value:
        return "–"  # NaN, as older files hold where there is no value: as null
    if isinstance(value, bool):
        return "yes" if value else "no"
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:,.4g}" if abs(value) < 1e6 else f"{value:,.0f}"
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, list) and all(not isinstance(v, (dict, list)) for v in value):
        return ", ".join(fmt(v) for v in value[:8]) + (" ..." if len(value) > 8 else "")
    if isinstance(value, (dict, list)):
        return "..."
    return clean(value)


def table(header, rows):
    ncol = len(header)
    tbl = nodes.table(classes=["results-table"])
    group = nodes.tgroup(cols=ncol)
    tbl += group
    for _ in range(ncol):
        group += nodes.colspec(colwidth=1)
    head = nodes.thead()
    group += head
    body = nodes.tbody()
    group += body
    for target, cells in ((head, [header]), (body, rows)):
        for cells_row in cells:
            row = nodes.row()
            for cell in cells_row:
                entry = nodes.entry()
                entry += nodes.paragraph(text=str(cell))
                row += entry
            target += row
    return tbl


def _scalar(v):
    return not isinstance(v, (dict, list)) or (
        isinstance(v, list) and all(not isinstance(x, (dict, list)) for x in v))


def _columns(items):
    cols = []
    for item in items:
        for k, v in item.items():
            if k not in cols and _scalar(v) and k not in META_KEYS:
                cols.append(k)
    return cols[:MAX_COLUMNS]


def _rows_table(label, items):
    """A table from (row label, mapping) pairs."""
    items = list(items)
    cols = _columns([m for _, m in items])
    rows = [[fmt(name)] + [fmt(m.get(c)) for c in cols] for name, m in items[:MAX_ROWS]]
    out = [table([label] + [clean(c) for c in cols], rows)]
    if len(items) > MAX_ROWS:
        out.append(nodes.paragraph(text=f"({len(items) - MAX_ROWS} more rows in the file.)"))
    return out


def _is_protocol_runs(obj):
    runs = obj.get("runs") if isinstance(obj, dict) else None
    return (isinstance(runs, list) and runs and isinstance(runs[0], dict)
            and isinstance(runs[0].get("rows"), list) and runs[0]["rows"]
            and {"method", "group", "error"} <= set(runs[0]["rows"][0]))


def _protocol_tables(obj):
    out = []
    for run in obj["runs"]:
        rows = [r for r in run["rows"] if r.get("end", "all") == "all"]
        groups, methods, cells = [], [], {}
        for r in rows:
            if r["group"] not in groups:
                groups.append(r["group"])
            if r["method"] not in methods:
                methods.append(r["method"])
            cells[r["method"], r["group"]] = r["error"]
        what = " · ".join(str(run[k]) for k in ("source", "split", "protocol", "dictionary")
                          if run.get(k) is not None)
        out.append(nodes.rubric(text=f"{what}: error, % of body height"))
        out.append(table(["method"] + groups,
                         [[clean(m)] + [fmt(cells.get((m, g))) for g in groups] for m in methods]))
    return out


def _is_real_people(obj):
    results = obj.get("results") if isinstance(obj, dict) else None
    return (isinstance(results, dict) and results
            and all(isinstance(r, dict) and isinstance(r.get("rows"), list) and r["rows"]
                    and {"method", "condition", "group", "mean"} <= set(r["rows"][0])
                    for r in results.values()))


def _real_people_tables(obj):
    """benchmarks/real_people.py's files: per source and condition, the mean error
    of each method (rows) by joint group or run length (columns), and its seconds."""
    out = []
    for source, result in obj["results"].items():
        conditions = []
        for r in result["rows"]:
            if r["condition"] not in conditions:
                conditions.append(r["condition"])
        for condition in conditions:
            rows = [r for r in result["rows"] if r["condition"] == condition]
            groups, methods, cells, own, jump = [], [], {}, {}, {}
            for r in rows:
                groups += [r["group"]] if r["group"] not in groups else []
                methods += [r["method"]] if r["method"] not in methods else []
                cells[r["method"], r["group"]] = r["mean"]
                if r["group"] == "overall":
                    own[r["method"]] = r.get("mean_own", r["mean"])
                    if "edge_jump" in r:
                        jump[r["method"]] = r["edge_jump"]
            seconds = result.get("seconds", {}).get(condition, {})
            extra = any(own[m] != cells[m, "overall"] for m in own)
            header = ["method"] + groups + (["overall, every hidden joint"] if extra else []) \
                + (["excess jump at gap edges"] if jump else [])
            body = [[clean(m)] + [fmt(cells.get((m, g))) for g in groups]
                    + ([fmt(own.get(m))] if extra else [])
                    + ([fmt(jump.get(m))] if jump else []) + [fmt(seconds.get(m))]
                    for m in methods]
            out.append(nodes.rubric(text=f"{source} · {condition}: mean error of the hidden "
                                         "joints, % of body size"))
            out.append(table(header + ["seconds"], body))
        notes = result.get("settings", {}).get("notes") or []
        for note in notes:
            out.append(nodes.paragraph(text=clean(note)))
    return out


def _is_paper_protocol(obj):
    runs = obj.get("paper_protocol") if isinstance(obj, dict) else None
    return isinstance(runs, dict) and runs and all(
        isinstance(r, dict) and isinstance(r.get("rows"), list) for r in runs.values())


#: the paper protocol's occlusion counts, as its rows name them, and their column titles
PAPER_COUNTS = {"1": "1 joint", "2": "2 joints", "3": "3 joints", "mix": "Mix"}


def paper_table(rows, representation):
    """Err_ave % per occlusion count, and the Mix joint error in pixels, a row
    per method of `rows` (``sparseedm evaluate``'s results.csv) under `representation`."""
    methods, cells = [], {}
    for r in rows:
        if r["representation"] != representation:
            continue
        methods += [r["method"]] if r["method"] not in methods else []
        cells[r["method"], str(r["count"])] = r
    body = [[clean(m)] + [fmt(cells[m, c]["err_ave_mean"]) if (m, c) in cells else "–"
                          for c in PAPER_COUNTS]
            + [fmt(cells[m, "mix"]["joint_err_px"]) if (m, "mix") in cells else "–"]
            for m in methods]
    return table(["method", *PAPER_COUNTS.values(), "Mix joint error, px"], body)


def sweep_table(sweep):
    """The atom-count sweep: Mix Err_ave % and recovery time per pose."""
    return table(["atoms", "Mix Err_ave %", "recovery ms / pose"],
                 [[fmt(r["atoms"]), fmt(r["err_ave_mix"]), fmt(r["ms_per_pose"])]
                  for r in sweep])


def _paper_tables(obj):
    out = []
    for run in obj["paper_protocol"].values():
        for representation in dict.fromkeys(r["representation"] for r in run["rows"]):
            out.append(nodes.rubric(text=f"{run.get('dictionary', '')} · {representation}: "
                                         "Err_ave %"))
            out.append(paper_table(run["rows"], representation))
        if run.get("sweep"):
            out.append(nodes.rubric(text="Error and time against the number of atoms"))
            out.append(sweep_table(run["sweep"]))
    return out


def _walk(obj, depth):
    out = []
    if isinstance(obj, list):
        if obj and all(isinstance(x, dict) for x in obj):
            first = next(iter(obj[0]))
            return _rows_table(first, [(x.get(first), {k: v for k, v in x.items() if k != first})
                                       for x in obj])
        return [nodes.paragraph(text=fmt(obj))]
    scalars = [(k, v) for k, v in obj.items() if _scalar(v) and k not in META_KEYS]
    if scalars:
        out.append(table(["", "value"], [[clean(k), fmt(v)] for k, v in scalars]))
    nested = {k: v for k, v in obj.items() if not _scalar(v) and k not in META_KEYS}
    if nested and all(isinstance(v, dict) for v in nested.values()) and all(
            sum(not _scalar(x) for x in v.values()) == 0 for v in nested.values()):
        return out + _rows_table("", nested.items())
    for key, value in nested.items():
        if _is_protocol_runs({"runs": value}) if key == "runs" else False:
            out += _protocol_tables({"runs": value})
            continue
        if depth >= 3:
            continue
        out.append(nodes.rubric(text=clean(key)))
        out += _walk(value, depth + 1)
    return out


def _meta_line(obj):
    parts = []
    meta = obj.get("meta", obj) if isinstance(obj, dict) else {}
    if meta.get("date"):
        parts.append(f"run {meta['date']}")
    machine = meta.get("machine")
    if isinstance(machine, dict):
        cores = machine.get("cores", machine.get("cpus"))
        parts.append(", ".join(p for p in (
            machine.get("cpu"), f"{cores} cores" if cores else None,
            f"Python {machine['python']}" if machine.get("python") else None) if p))
    elif machine:
        parts.append(clean(machine))
    for key in ("loadavg_start", "load_average", "load_average_before", "load_start"):
        value = meta.get(key) or (machine.get(key) if isinstance(machine, dict) else None)
        if value:
            parts.append(f"load average at start {fmt(value)}")
            break
    return "; ".join(p for p in parts if p)


def render(path):
    obj = json.loads(path.read_text(encoding="utf-8"))
    rel = path.relative_to(ROOT).as_posix()
    section = nodes.section(ids=[nodes.make_id(rel)])
    section += nodes.title(text=TITLES.get(path.name, path.stem))
    para = nodes.paragraph()
    para += nodes.literal(text=rel)
    line = _meta_line(obj)
    if line:
        para += nodes.Text(f" ({line})")
    section += para
    body = (_protocol_tables(obj) if _is_protocol_runs(obj)
            else _real_people_tables(obj) if _is_real_people(obj)
            else _paper_tables(obj) if _is_paper_protocol(obj) else _walk(obj, 0))
    for node in body:
        section += node
    return section


#: the real-people files the summary table reads, and how their rows are named
SUMMARY_FILES = {"results-real-people-val.json": "",
                 "results-real-people-val-train-complete.json": ", training poses added"}
#: the summary's columns: sparseedm's methods as the files name them
SUMMARY_OURS = {"sparseedm": "sparseedm defaults", "sparseedm-no-adapt": "adapt=False"}


def summary_rows():
    """One row per real-people file, source and condition: the overall mean error of
    sparseedm's methods, of IterativeImputer, and of the best other peer."""
    out = []
    for name, suffix in SUMMARY_FILES.items():
        path = ROOT / "benchmarks" / name
        if not path.is_file():
            continue
        for source, result in json.loads(path.read_text(encoding="utf-8"))["results"].items():
            overall = {}
            for r in result["rows"]:
                if r["group"] == "overall":
                    overall.setdefault(r["condition"], {})[r["method"]] = r["mean"]
            for condition, means in overall.items():
                peers = {m: v for m, v in means.items()
                         if m not in SUMMARY_OURS and m != "per-frame" and known(v)}
                best = min(peers, key=peers.get) if peers else None
                out.append([f"{source}{suffix} · {condition}"]
                           + [fmt(means.get(m)) for m in SUMMARY_OURS]
                           + [fmt(means.get("iterative")),
                              f"{best} {fmt(peers[best])}" if peers else fmt(None)])
    return out


class RealPeopleSummary(Directive):
    """The real-people files' overall errors in one table (``real-people-summary``)."""

    def run(self):
        env = self.state.document.settings.env
        for name in SUMMARY_FILES:
            env.note_dependency(str(ROOT / "benchmarks" / name))
        header = ["file · condition", *SUMMARY_OURS.values(), "IterativeImputer", "best peer"]
        return [table(header, summary_rows())]


def missing(name, command):
    """What a summary shows while its results file has not been written yet."""
    para = nodes.paragraph(text=f"No benchmarks/{name} yet: ")
    para += nodes.literal(text=command)
    para += nodes.Text(" writes it.")
    return [para]


#: the paper protocol's file and the command that writes it
PAPER_FILE = "results-paper-protocol.json"
PAPER_COMMAND = ("python -m benchmarks.paper_protocol --sweep-atoms 100,250,500,1000,2000 "
                 "--write-docs")


class PaperProtocolSummary(Directive):
    """The paper protocol's headline tables (``paper-protocol-summary``): every
    method on the dictionary learned on the training set, the sparse row of each
    dictionary evaluated, and the atom sweep."""

    def run(self):
        path = ROOT / "benchmarks" / PAPER_FILE
        self.state.document.settings.env.note_dependency(str(path))
        if not path.is_file():
            return missing(PAPER_FILE, PAPER_COMMAND)
        obj = json.loads(path.read_text(encoding="utf-8"))
        runs = obj["paper_protocol"]
        first = next(iter(runs.values()))
        representation = first["rows"][0]["representation"]
        para = nodes.paragraph(text=f"{first['dictionary']}, every method ({representation} "
                                    f"representation; {_meta_line(obj)}):")
        out = [para, paper_table(first["rows"], representation)]
        sparse = [dict(r, method=run["dictionary"]) for run in runs.values()
                  for r in run["rows"] if r["method"] == "sparse"]
        out += [nodes.paragraph(text="sparseedm with each dictionary on the same poses:"),
                paper_table(sparse, representation)]
        if first.get("sweep"):
            out += [nodes.paragraph(text="Error and time against the number of atoms "
                                         "(dictionaries learned on the same training set):"),
                    sweep_table(first["sweep"])]
        return out


#: the video protocols' file the video summary reads, its gap fillers and its model
VIDEO_FILE = "results-video-intervals-all.json"
VIDEO_FILLERS = ("linear", "cubic", "akima", "pca")
VIDEO_MODEL = "temporal"


def video_rows(obj):
    """Per run of the video protocols: the temporal model's overall error, the best
    gap filler's, their ratio, and the largest ratio over the run's bins."""
    out = []
    for run in obj["runs"]:
        cells = {(r["method"], r["group"]): r["error"] for r in run["rows"]
                 if r.get("end", "all") == "all" and known(r["error"])}
        groups = list(dict.fromkeys(g for _, g in cells))
        best = {g: min((cells[m, g], m) for m in VIDEO_FILLERS if (m, g) in cells)
                for g in groups if any((m, g) in cells for m in VIDEO_FILLERS)}
        ratio = {g: cells[VIDEO_MODEL, g] / best[g][0] for g in best
                 if (VIDEO_MODEL, g) in cells}
        if "overall" not in ratio:
            continue
        out.append([f"{run.get('source')} · {run.get('split')} · {run.get('protocol')}",
                    fmt(cells[VIDEO_MODEL, "overall"]),
                    f"{best['overall'][1]} {fmt(best['overall'][0])}",
                    f"{ratio['overall']:.2f}x", f"{max(ratio.values()):.2f}x"])
    return out


class VideoSummary(Directive):
    """The video protocols' headline (``video-summary``): the temporal model against
    the best gap filler, per source, split and protocol."""

    def run(self):
        path = ROOT / "benchmarks" / VIDEO_FILE
        self.state.document.settings.env.note_dependency(str(path))
        if not path.is_file():
            return missing(VIDEO_FILE, "python benchmarks/video_protocols.py")
        obj = json.loads(path.read_text(encoding="utf-8"))
        return [table(["source · split · protocol", "temporal model", "best gap filler",
                       "ratio", "worst bin's ratio"], video_rows(obj))]


#: the lifting files the 3D summary reads
LIFT_FILES = ("results-lifting.json", "results-lifting-fconv.json")
#: the application table's pipelines the 3D summary shows, and how it names them
LIFT_PIPELINES = {"complete": "complete input", "as-is average": "occluded input as is",
                  "applyspar": "recovered by sparseedm, then lifted"}


def lift_rows(obj):
    """The dictionary lifter's rows of the application table at Mix (and on
    complete input): 3D-EDM Err_ave %, PA-MPJPE and the share of right reflections."""
    rows = [r for r in obj.get("table", []) + obj.get("applyspar_shipped_2d_dictionary", [])
            if r["lifter"] == "dictionary" and r["pipeline"] in LIFT_PIPELINES
            and str(r["count"]) in ("mix", "none")]
    rows.sort(key=lambda r: list(LIFT_PIPELINES).index(r["pipeline"]))
    return [[LIFT_PIPELINES[r["pipeline"]], fmt(r["err3d"]), fmt(r["pa_mpjpe"]),
             f"{100 * r['reflection_ok']:.1f} %" if known(r["reflection_ok"]) else fmt(None)]
            for r in rows]


class LiftSummary(Directive):
    """The 3D headline (``lift-summary``): the dictionary lifter through its joint
    lasso against the MLP (results-lifting.json), and the dictionary lifter's
    pipelines of the application table (results-lifting-fconv.json)."""

    def run(self):
        env = self.state.document.settings.env
        out = []
        for name in LIFT_FILES:
            env.note_dependency(str(ROOT / "benchmarks" / name))
        path = ROOT / "benchmarks" / LIFT_FILES[0]
        if path.is_file():
            obj = json.loads(path.read_text(encoding="utf-8"))
            val = obj["cmu_validation"]
            out.append(nodes.paragraph(text=(
                f"benchmarks/{LIFT_FILES[0]} ({_meta_line(obj)}): {fmt(val['n_poses'])} "
                "poses of held-out CMU clips, 3D-EDM Err_ave %, both lifters learned on "
                f"the same {fmt(obj['n_train'])} training poses; Mix occluded joints go "
                "through the dictionary lifter's joint lasso as they are:")))
            out.append(table(["lifter", "complete input", "Mix"],
                             [[clean(k), fmt(v["complete"]), fmt(v["mix"])]
                              for k, v in val.items() if isinstance(v, dict)]))
        path = ROOT / "benchmarks" / LIFT_FILES[1]
        if path.is_file():
            obj = json.loads(path.read_text(encoding="utf-8"))
            out.append(nodes.paragraph(text=(
                f"benchmarks/{LIFT_FILES[1]} (sparseedm evaluate-lift; {clean(obj['data'])}): "
                "the dictionary lifter at Mix:")))
            out.append(table(["input", "3D-EDM Err_ave %", "PA-MPJPE, mm",
                              "depth reflection right"], lift_rows(obj)))
        return out or missing(LIFT_FILES[0], "python -m benchmarks.lifting --cmu TRAIN.npz")


class BenchmarkResults(Directive):
    """Render the results files assigned to one page."""

    required_arguments = 1

    def run(self):
        env = self.state.document.settings.env
        out = []
        for path in files_for(self.arguments[0]):
            env.note_dependency(str(path))
            out.append(render(path))
        return out


def setup(app):
    app.add_directive("benchmark-results", BenchmarkResults)
    app.add_directive("real-people-summary", RealPeopleSummary)
    app.add_directive("paper-protocol-summary", PaperProtocolSummary)
    app.add_directive("lift-summary", LiftSummary)
    app.add_directive("video-summary", VideoSummary)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
