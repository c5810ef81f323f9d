"""The study "plan on the completion, score on the truth": one real view through T, C and P,
the tables against a hand count, and the run resumed from its files."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from symjax import configs
from symjax.datasets import benchmark
from symjax.study import PLANNING_MESHES, StudyConfig, runner, summarise, write_report
from symjax.study.protocol import study_view


@pytest.fixture(scope="module")
def cfg(tmp_path_factory):
    return StudyConfig.from_preset(configs.load("study"), hands=(("barrett", "uji"),), top=3,
                                   backend="mujoco", extra_scans=(),
                                   out_dir=str(tmp_path_factory.mktemp("study")))  # fmt: skip


@pytest.mark.slow
def test_one_view_planned_on_each_mesh_and_scored_on_the_truth(cfg):
    view = benchmark(["025_mug/000"], seed=0, workers=1)[0]
    meshes = runner.planning_meshes([view], cfg)[0]
    assert set(meshes) == {"C", "K", "P"}
    shapes = meshes["K"]
    assert shapes.meshes[0] is meshes["C"] and len(shapes) == cfg.completion.shapes
    assert shapes.weights[0] >= 0.5 and np.isclose(shapes.weights.sum(), 1.0)
    for m in (meshes["C"], meshes["P"], *shapes.meshes):
        assert m.is_watertight and m.vertices[:, 2].min() >= -1e-6  # cut at the table (z = 0)
    rec = study_view(view, meshes, cfg)
    rows = rec["hands"]["barrett"]
    for k in PLANNING_MESHES:
        r = rows[k]
        assert r["error"] is None and r["planned"] >= cfg.top
        assert len(r["predicted"]) == len(r["truth"]) == cfg.top
        assert r["seconds"] > 0
    # K's prediction is the weighted mean success over its shapes, best first.
    assert all(0.0 <= p <= 1.0 for p in rows["K"]["predicted"])
    assert rows["K"]["predicted"] == sorted(rows["K"]["predicted"], reverse=True)
    assert rows["K"]["shapes"]["kinds"][0] in ("mirror", "revolution")
    # Each shape's rollouts are kept: their weighted mean is the prediction.
    ss = np.asarray(rows["K"]["shapes"]["success"], float)
    assert ss.shape == (len(shapes), cfg.top)
    np.testing.assert_allclose(shapes.weights @ ss, rows["K"]["predicted"], atol=1e-4)
    # Planned on the truth and scored on the truth: the same rollouts, bit for bit.
    assert rows["T"]["truth"] == rows["T"]["predicted"]
    assert all(rows["T"]["truth"])  # the top of a plan on the true mug succeeds


def _record(name, obj, deg, rows):
    return {"view": name, "object": obj, "orientation_deg": deg, "hands": {"sdh": rows}}


def test_tables_count_every_top_grasp():
    full = {"predicted": [True] * 5, "truth": [True] * 5, "planned": 9, "error": None}
    half = {"predicted": [True] * 5, "truth": [True, False, True, False, False], "planned": 9,
            "error": None}  # fmt: skip
    none = {"predicted": [], "truth": [], "planned": 0, "error": "EmptyInputError: x"}
    recs = [_record("a/000", "a", 0.0, {"T": full, "C": full, "P": half}),
            _record("b/090", "b", 90.0, {"T": full, "C": half, "P": none}),
            {"view": "c/000", "error": "SymjaxError: broken", "hands": {}}]  # fmt: skip
    s = summarise(recs, top=5)
    assert s["views"] == 2 and s["failed_views"] == 1
    h = s["hands"]["sdh"]
    assert h["T"]["success"] == 100.0
    assert h["C"]["success"] == pytest.approx(100 * (5 + 2) / 10)
    assert h["P"]["success"] == pytest.approx(100 * 2 / 10)  # no plan counts 0 of 5
    assert h["P"]["no_plan"] == 1 and h["P"]["success_of_planned"] == pytest.approx(40.0)
    assert h["T-C"] == pytest.approx(30.0) and h["T-P"] == pytest.approx(80.0)
    assert h["C"]["predicted"] == 100.0
    assert s["by_object"]["sdh"]["b"] == {"T": 100.0, "C": 40.0, "P": 0.0}
    assert s["by_orientation"]["sdh"]["90.0"]["C"] == 40.0
    # Brier: C predicts 1 for 10 grasps of which 3 fail on the truth.
    assert h["C"]["brier"] == pytest.approx(0.3) and h["T"]["brier"] == 0.0
    assert "P" in h["overconfidence_ci95"] and "T" not in h["overconfidence_ci95"]


def _rows(pred, truth):
    return [{"predicted": list(p), "truth": list(t)} for p, t in zip(pred, truth, strict=True)]


def test_prediction_intervals_resample_views():
    from symjax.study.summary import prediction_intervals

    rng = np.random.default_rng(3)
    truth = rng.random((40, 5)) < 0.8
    exact = _rows(truth.astype(float), truth)  # predicts every grasp right
    sure = _rows(np.ones((40, 5)), truth)  # over-confident wherever a grasp fails
    out = prediction_intervals({"C": sure, "K": exact}, resamples=500, seed=1)
    gap = 100 * (1 - truth.mean())
    assert out["K"] == [0.0, 0.0]
    assert out["C"][0] < gap < out["C"][1]
    assert out["K_vs_C"]["abs_gap_change"] == pytest.approx(-gap, abs=0.01)
    assert out["K_vs_C"]["share_K_closer"] == 1.0 and out["K_vs_C"]["interval"][1] < 0
    # The same predictions: no change, and K is never the closer one.
    same = prediction_intervals({"C": sure, "K": sure}, resamples=200)["K_vs_C"]
    assert same == {"abs_gap_change": 0.0, "interval": [0.0, 0.0], "share_K_closer": 0.0}
    # Reproducible: the same seed resamples the same views.
    assert prediction_intervals({"C": sure}, resamples=300, seed=5) == prediction_intervals(
        {"C": sure}, resamples=300, seed=5
    )


def test_study_resumes_from_its_files(cfg, tmp_path, monkeypatch):
    calls = []

    class View:
        def __init__(self, name):
            self.name = name

    monkeypatch.setattr(
        runner, "study_views", lambda c: [(n, lambda n=n: View(n)) for n in ("a/000", "b/045")]
    )
    monkeypatch.setattr(runner, "planning_meshes", lambda views, c: [{} for _ in views])

    def fake(view, meshes, c):
        calls.append(view.name)
        row = {"predicted": [True], "truth": [bool(len(calls) % 2)], "planned": 1, "error": None}
        return {"view": view.name, "object": view.name[0], "orientation_deg": 0.0,
                "hands": {"sdh": {k: row for k in PLANNING_MESHES}}}  # fmt: skip

    monkeypatch.setattr(runner, "study_view", fake)
    c = dataclasses.replace(cfg, out_dir=str(tmp_path))
    first = runner.run_study(c, log=lambda s: None)
    assert calls == ["a/000", "b/045"] and len(first) == 2
    runner.run_study(c, log=lambda s: None)
    assert len(calls) == 2  # resumed
    (tmp_path / "views" / "b_045.json").write_text("[broken")
    runner.run_study(c, log=lambda s: None)
    assert calls[2:] == ["b/045"]
    runner.run_study(dataclasses.replace(c, top=2), log=lambda s: None)  # another key
    assert len(calls) == 5
    s = write_report(first, tmp_path, top=1)
    assert (tmp_path / "study.png").stat().st_size > 1000
    report = (tmp_path / "report.md").read_text()
    assert "| sdh |" in report and "## The planner's prediction of success" in report
    assert "| sdh | C |" in report
    assert np.isfinite(s["hands"]["sdh"]["T-C"])
