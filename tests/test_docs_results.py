"""The documentation's results directives read what the benchmarks write.

docs/_ext/results.py renders the results pages from ``benchmarks/results*.json``;
these tests feed its summaries small documents of the benchmarks' shapes (and
one written by benchmarks/paper_protocol.py's collector from report CSVs) and
check the cells they make.
"""

import csv
import json
import sys
from pathlib import Path

import pytest

pytest.importorskip("docutils", reason="needs the [docs] extra")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))
import results  # noqa: E402

from benchmarks.paper_protocol import DICTIONARIES, collect  # noqa: E402


def cells(tbl):
    """A docutils table's rows as lists of text, header first."""
    return [[entry.astext() for entry in row.children] for row in tbl.findall(
        lambda n: n.tagname == "row")]


def _report(folder, sparse_mix, sweep=None):
    folder.mkdir(parents=True)
    rows = [dict(method=m, representation=rep, count=c, err_ave_mean=e, joint_err_px=10 * e)
            for rep in ("average", "zero") for m, base in (("sparse", sparse_mix), ("knn", 5.0))
            for c, e in (("1", base / 2), ("2", base), ("mix", base))]
    with open(folder / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    if sweep:
        with open(folder / "sweep.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=["atoms", "err_ave_mix", "ms_per_pose",
                                              "fit_seconds", "note"])
            w.writeheader()
            w.writerows(sweep)


def test_paper_protocol_collected_then_rendered(tmp_path):
    for k, name in enumerate(DICTIONARIES):
        _report(tmp_path / f"report-{name}", 2.0 + k,
                [dict(atoms=100, err_ave_mix=3.5, ms_per_pose=0.2, fit_seconds=1, note="")])
    doc = collect(tmp_path, {"date": "today"}, {"train_poses": 10, "test_poses": 5}, sweep=True)
    assert results._is_paper_protocol(doc)
    first = next(iter(doc["paper_protocol"].values()))
    got = cells(results.paper_table(first["rows"], "average"))
    assert got[0] == ["method", "1 joint", "2 joints", "3 joints", "Mix", "Mix joint error, px"]
    assert got[1] == ["sparse", "1", "2", "–", "2", "20"]      # no 3-joint row: a dash
    assert got[2][0] == "knn" and len(got) == 3
    assert cells(results.sweep_table(first["sweep"]))[1] == ["100", "3.5", "0.2"]
    without = collect(tmp_path, {}, {}, sweep=False)
    assert all("sweep" not in run for run in without["paper_protocol"].values())


def test_video_summary_takes_the_best_filler_per_run():
    rows = [dict(method=m, group=g, error=e) for m, g, e in (
        ("linear", "gap 3", 4.0), ("cubic", "gap 3", 2.0), ("temporal", "gap 3", 1.0),
        ("linear", "overall", 8.0), ("pca", "overall", 5.0), ("temporal", "overall", 2.0))]
    rows.append(dict(method="temporal", group="overall", error=99.0, end="start"))
    out = results.video_rows({"runs": [dict(source="cmu", split="test", protocol="gaps",
                                            rows=rows)]})
    assert out == [["cmu · test · gaps", "2", "pca 5", "0.40x", "0.50x"]]


def test_lift_summary_rows_are_the_dictionary_lifters_at_mix():
    row = dict(lifter="dictionary", err3d=4.0, pa_mpjpe=40.0, reflection_ok=0.995)
    doc = {"table": [dict(row, pipeline="as-is average", count="mix", err3d=20.0),
                     dict(row, pipeline="complete", count="none", err3d=3.0),
                     dict(row, pipeline="as-is average", count=1, err3d=9.0),
                     dict(row, lifter="mlp", pipeline="complete", count="none")],
           "applyspar_shipped_2d_dictionary": [dict(row, pipeline="applyspar", count="mix")]}
    assert results.lift_rows(doc) == [
        ["complete input", "3", "40", "99.5 %"],
        ["occluded input as is", "20", "40", "99.5 %"],
        ["recovered by sparseedm, then lifted", "4", "40", "99.5 %"]]


def test_summaries_read_null_where_there_is_no_value(tmp_path, monkeypatch):
    """sparseedm's reports write null where a value is missing (older files: NaN): the
    summaries show a dash there and take the best of the values they have."""
    from sparseedm.evaluation_real import RealReport

    nan = float("nan")
    rows = [dict(method=m, condition="mix", group="overall", mean=v) for m, v in (
        ("sparseedm", 2.0), ("sparseedm-no-adapt", nan), ("iterative", 4.0), ("knn", nan),
        ("nearest", 3.0))]
    report = RealReport("photos", rows, {"mix": {}}, {})
    assert '"mean": null' in report.to_json()
    folder = tmp_path / "benchmarks"
    folder.mkdir()
    (folder / "results-real-people-val.json").write_text(
        '{"results": {"coco photos": ' + report.to_json() + "}}")
    monkeypatch.setattr(results, "ROOT", tmp_path)
    assert results.summary_rows() == [["coco photos · mix", "2", "–", "4", "nearest 3"]]
    doc = json.loads((folder / "results-real-people-val.json").read_text())
    assert cells(results._real_people_tables(doc)[1])[1:3] == [
        ["sparseedm", "2", "–"], ["sparseedm-no-adapt", "–", "–"]]  # seconds: none

    video = [dict(method=m, group=g, error=e) for m, g, e in (
        ("linear", "gap 3", None), ("cubic", "gap 3", 2.0), ("temporal", "gap 3", None),
        ("linear", "overall", 8.0), ("pca", "overall", None), ("temporal", "overall", 2.0))]
    assert results.video_rows({"runs": [dict(source="cmu", split="test", protocol="gaps",
                                             rows=video)]}) == [
        ["cmu · test · gaps", "2", "linear 8", "0.25x", "0.25x"]]
    lift = dict(lifter="dictionary", pipeline="complete", count="none", err3d=3.0,
                pa_mpjpe=None, reflection_ok=None)
    assert results.lift_rows({"table": [lift]}) == [["complete input", "3", "–", "–"]]
