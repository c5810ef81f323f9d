"""scripts/eval_dataset.py end to end on a 4-view subset, resume, and bad arguments."""

from __future__ import annotations

import csv
import importlib.util
import json
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
METHODS = ("Del", "Mir5", "Mir7")


def _script():
    spec = importlib.util.spec_from_file_location(
        "eval_dataset", ROOT / "scripts" / "eval_dataset.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def script():
    return _script()


@pytest.fixture(scope="module")
def run4(script, tmp_path_factory):
    """One evaluation of the first 4 views in batches of 2 (two batches, one compile)."""
    out = tmp_path_factory.mktemp("eval4")
    argv = [
        "--out-dir", str(out), "--subset", "4", "--execution.eval-batch-size", "2",
        "--gallery", "2", "--execution.no-progress",
    ]  # fmt: skip
    assert script.main(argv) == 0
    return out, argv


def test_outputs_exist_and_are_consistent(run4):
    out, _ = run4
    for name in ("results.csv", "results.json", "report.md"):
        assert (out / name).is_file(), name
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert len(rows) == 4 * len(METHODS)
    views = sorted({r["view"] for r in rows})
    assert len(views) == 4
    assert {(r["view"], r["method"]) for r in rows} == {(v, m) for v in views for m in METHODS}
    for r in rows:
        assert r["ok"] == "True", r
        for k in ("dev_mean_mm", "dev_var_mm2", "centroid_error", "build_s", "metric_s"):
            assert math.isfinite(float(r[k])), (k, r)
        assert float(r["dev_mean_mm"]) >= 0 and float(r["dev_var_mm2"]) >= 0
        assert 0 <= float(r["centroid_error"]) < 1
        assert int(r["n_faces"]) > 0
    data = json.loads((out / "results.json").read_text())
    assert len(data["rows"]) == len(rows)
    assert data["summary"]["n_views"] == 4
    for m in METHODS:
        mean = sum(float(r["dev_mean_mm"]) for r in rows if r["method"] == m) / 4
        assert data["summary"]["methods"][m]["dev_mean_mm"] == pytest.approx(mean, rel=1e-4)
    # One result file per view (what resume reads).
    assert len(list((out / "views").glob("*.json"))) == 4

    report = (out / "report.md").read_text()
    figs = ["fig10_orientation.png", "fig11_objects.png", "fig12_centroid.png", "gallery.png"]
    for f in figs:
        assert (out / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f
        assert f"]({f})" in report, f
    for m in METHODS:
        assert f"| {m} |" in report
    # Which completion each view got, and why, in the table, the records and the report.
    for r in rows:
        assert r["completion"] in ("mirror", "revolution", "fallback")
        assert 0.0 < float(r["confidence"]) < 1.0
    for v in views:
        rec = json.loads((out / "views" / (v.replace("/", "__") + ".json")).read_text())
        sym = rec["symmetry"]
        assert (
            sym["completion"] in sym["completion_reason"]
            or "confidence" in sym["completion_reason"]
        )
        assert f"| {v} | {sym['completion']} |" in report
    assert "## Completion of each view" in report and "ROC AUC" in report


def test_records_of_older_runs_read_with_the_paper_completion():
    """A record written before the completion choice existed still parses: it was mirrored."""
    from symjax.evaluation.records import PlaneResult

    old = {"normal": [1.0, 0.0, 0.0], "offset_m": 0.1, "vote": 3.0, "n_mirrored": 5}
    p = PlaneResult.from_json(old)
    assert p.completion == "mirror" and math.isnan(p.confidence) and p.completion_reason == ""
    new = PlaneResult(
        (1.0, 0.0, 0.0), 0.1, 3.0, 2.0, 1.0, support=0.4, rival_support=0.2, confidence=0.9,
        completion="revolution", completion_reason="r", revolution_residual=0.1,
    )  # fmt: skip
    assert PlaneResult.from_json(json.loads(json.dumps(new.to_json()))) == new


def test_resume_skips_done_views(script, run4, capsys):
    out, argv = run4
    files = sorted((out / "views").glob("*.json"))
    before = {p: p.stat().st_mtime_ns for p in files}
    assert script.main(argv) == 0
    assert "4 already done" in capsys.readouterr().out
    assert {p: p.stat().st_mtime_ns for p in files} == before


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--methods", "Del", "Foo"], "unknown method 'Foo'"),
        (["--execution.eval-batch-size", "0"], "eval_batch_size must be an integer >= 1, got 0"),
        (["--execution.eval-batch-size", "two"], "invalid literal for int()"),
        (["--subset", "no_such_object"], "no_such_object"),
        (["--subset", "xdeg"], "orientation"),
        (["--no-such-flag"], "Unrecognized options: --no-such-flag"),
        (["--n-samples", "3"], "n_samples must be an int >= 100, got 3"),
        (["--data", "/no/such/folder"], "does not exist"),
        (["--config", "no_such_preset"], "unknown preset 'no_such_preset'"),
        (["--symmetry.w-outside", "nan"], "w_outside"),
    ],
)
def test_bad_arguments(script, tmp_path, capsys, argv, needle):
    assert script.main(["--out-dir", str(tmp_path / "o"), "--execution.no-progress", *argv]) == 2
    err = capsys.readouterr().err
    # tyro frames its parse errors in a box; the message may wrap inside it.
    flat = " ".join(line.strip(" │╭╰─╮╯") for line in err.splitlines())
    assert needle in " ".join(flat.split())
    assert "Traceback" not in err


def test_empty_and_malformed_data_folder(script, tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    quiet = "--execution.no-progress"
    assert script.main(["--out-dir", str(tmp_path / "o"), "--data", str(empty), quiet]) != 0
    err = capsys.readouterr().err
    assert "segment_" in err and "Traceback" not in err

    bad = tmp_path / "bad" / "cup"
    bad.mkdir(parents=True)
    (bad / "segment_0.crd").write_text("not a point file\n")
    (bad / "viewPoint_0.txt").write_text("garbage\n")
    (bad / "calib.txt").write_text("garbage\n")
    assert script.main(["--out-dir", str(tmp_path / "o"), "--data", str(bad.parent), quiet]) != 0
    err = capsys.readouterr().err
    assert "error" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def _write_kth(folder: Path, view, deg: int) -> None:
    """A benchmark view written in the KTH database layout (mm, pixel coordinates, calib)."""
    import numpy as np

    cam = view.camera
    K = np.asarray(cam.K, float)
    uv, _ = cam.project(view.points)
    uv = np.rint(np.asarray(uv)).astype(int)
    rows = np.column_stack([view.points * 1000, uv, np.full((len(uv), 3), 128)])
    folder.mkdir(parents=True, exist_ok=True)
    body = "\n".join(
        " ".join(f"{x:.6f}" if i < 3 else f"{int(x)}" for i, x in enumerate(r)) for r in rows
    )
    (folder / f"segment_{deg:03d}.crd").write_text(f"{len(rows)}\n{body}")
    vp = np.asarray(cam.position) * 1000
    (folder / f"viewPoint_{deg:03d}.txt").write_text(" ".join(f"{x:.6f}" for x in vp))
    h, w = view.depth.shape
    k = [K[0, 0], K[0, 1], K[0, 2], 0, K[1, 1], K[1, 2], 0, 0, 1, 0, 0, 0, 0]
    nums = k * 2 + [90, 0, 0, 1, 0, 0, 0] + [0] * 9 + [w, h] + [0] * 18
    (folder.parent / "calib.txt").write_text(" ".join(str(x) for x in nums))


def test_kth_layout_without_ground_truth(script, tmp_path, capsys):
    from symjax.datasets import benchmark

    for v in benchmark(["025_mug/000", "025_mug/090"]):
        _write_kth(tmp_path / "db" / "mug", v, int(v.orientation_deg))
    out = tmp_path / "out"
    argv = [
        "--data", str(tmp_path / "db"), "--out-dir", str(out), "--gallery", "2",
        "--execution.no-progress",
    ]  # fmt: skip
    assert script.main(argv) == 0
    assert "no ground truth" in capsys.readouterr().out
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert sorted({r["view"] for r in rows}) == ["mug/000", "mug/090"]
    assert len(rows) == 2 * len(METHODS)
    for r in rows:
        assert r["ok"] == "True" and int(r["n_faces"]) > 0
        assert r["dev_mean_mm"] == "nan" and r["plane_error_deg"] == "nan"
    assert (out / "gallery.png").read_bytes()[:4] == b"\x89PNG"
    assert not (out / "fig10_orientation.png").exists()


def test_malformed_view_file_is_recomputed_with_a_warning(script, run4, capsys):
    out, argv = run4
    files = sorted((out / "views").glob("*.json"))
    files[0].write_text("null")
    files[1].write_text(json.dumps({"view": "x"}))  # parseable, a field missing
    assert script.main(argv) == 0
    text = capsys.readouterr().out
    assert "2 to evaluate" in text and text.count("is malformed") == 2
    for f in files[:2]:
        assert json.loads(f.read_text())["view"]  # rewritten whole


def test_other_settings_never_overwrite_a_folder(script, run4, capsys):
    out, argv = run4
    before = (out / "results.csv").read_bytes()
    other = [a if a != "4" else "2" for a in argv]  # a smaller subset
    assert script.main(other) == 2
    assert "another selection of views" in capsys.readouterr().err
    assert script.main([*argv, "--symmetry.n-refine", "1"]) == 2
    assert "other settings" in capsys.readouterr().err
    assert (out / "results.csv").read_bytes() == before


def test_ctrl_c_stops_the_command_promptly(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    exe = Path(sys.executable).with_name("symjax")
    env = {**os.environ, "SYMJAX_CACHE": str(tmp_path / "cache"), "MPLBACKEND": "Agg"}
    p = subprocess.Popen(
        [str(exe), "eval", "--subset", "025_mug", "--out-dir", str(tmp_path / "o"),
         "--execution.no-progress"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    time.sleep(4.0)
    t0 = time.perf_counter()
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err[-2000:]
    assert time.perf_counter() - t0 < 10.0
    assert "interrupted" in err and "Traceback" not in err


def test_ctrl_c_while_the_command_imports(monkeypatch, capsys):
    """The interrupt can land before the command's own handler exists (CI's 2 cores took over
    4 s to import mujoco): still status 130 and one line, not Python's SIGINT death."""
    from symjax import cli

    def importing(argv):
        raise KeyboardInterrupt

    monkeypatch.setitem(cli.COMMANDS, "eval", (importing, "stub"))
    assert cli.main(["eval"]) == 130
    err = capsys.readouterr().err
    assert err.strip() == "symjax eval: interrupted before it started"
