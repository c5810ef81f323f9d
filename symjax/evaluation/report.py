"""Summary numbers, ``results.csv`` / ``results.json`` and the one-page ``report.md``."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from symjax._atomic import atomic_write_json, atomic_write_text
from symjax.evaluation.figures import group_stats
from symjax.evaluation.records import ROW_FIELDS, ViewRecord, jsonable

__all__ = ["PAPER", "summarize", "write_report", "write_tables"]

#: The paper's findings (Section V-A.4 and V-B) checked on the benchmark.
PAPER = {"mir7_mean_mm": 7.0, "centroid_max": 0.10}


def _mean(x) -> float:
    x = np.asarray(list(x), float)
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else math.nan


def summarize(
    records: Sequence[ViewRecord], rows: Sequence[dict[str, Any]], methods: Sequence[str]
) -> dict[str, Any]:
    """Aggregates: per method overall / per orientation / per data set, planes, timings, checks.

    Deviation in mm (mean over views of each view's mean), variance in mm^2, centroid error as a
    fraction of the box diagonal; failed reconstructions are counted and left out of the means.
    """
    out: dict[str, Any] = {"methods": {}, "n_views": len(records)}
    for m in methods:
        rs = [r for r in rows if r["method"] == m]
        out["methods"][m] = {
            "n": len(rs),
            "n_failed": sum(not r["ok"] for r in rs),
            "dev_mean_mm": _mean(r["dev_mean_mm"] for r in rs),
            "dev_var_mm2": _mean(r["dev_var_mm2"] for r in rs),
            "centroid_error": _mean(r["centroid_error"] for r in rs),
        }
    for key, name in (("orientation_deg", "per_orientation"), ("dataset", "per_dataset")):
        groups, mean, _ = group_stats(rows, key, "dev_mean_mm", methods)
        _, var, _ = group_stats(rows, key, "dev_var_mm2", methods)
        _, cen, _ = group_stats(rows, key, "centroid_error", methods)
        out[name] = {
            str(g): {
                m: {
                    "dev_mean_mm": float(mean[m][i]),
                    "dev_var_mm2": float(var[m][i]),
                    "centroid_error": float(cen[m][i]),
                }
                for m in methods
            }
            for i, g in enumerate(groups)
        }
    nan = math.nan
    deg = np.array([nan if r.symmetry is None else r.symmetry.plane_error_deg for r in records])
    mm = np.array([nan if r.symmetry is None else r.symmetry.plane_error_mm for r in records])
    ok = np.isfinite(deg)
    out["plane_error"] = {
        "n": int(ok.sum()),
        "median_deg": float(np.median(deg[ok])) if ok.any() else math.nan,
        "mean_deg": float(deg[ok].mean()) if ok.any() else math.nan,
        "median_mm": float(np.median(mm[ok])) if ok.any() else math.nan,
        "mean_mm": float(mm[ok].mean()) if ok.any() else math.nan,
        "frac_within_10deg_10mm": float(np.mean((deg[ok] <= 10) & (mm[ok] <= 10)))
        if ok.any()
        else math.nan,
    }
    out["completion"] = _completion_summary(records, rows)
    stages: dict[str, float] = {}
    for r in records:
        for k, v in r.timings_s.items():
            stages[k] = stages.get(k, 0.0) + _num(v)
    out["timings_s"] = {k: stages[k] for k in sorted(stages)}
    out["checks"] = _checks(out, methods)
    return out


def _num(x: Any) -> float:
    return math.nan if x is None else float(x)


def _completion_summary(records: Sequence[ViewRecord], rows: Sequence[dict[str, Any]]):
    """Views per completion kind with their Mir7 mean, and how well the confidence separates
    planes off by more than 10 deg or 10 mm (ROC AUC) from the rest."""
    from symjax.completion import roc_auc

    mir7 = {r["view"]: r["dev_mean_mm"] for r in rows if r["method"] == "Mir7"}
    kinds: dict[str, list[float]] = {}
    for r in records:
        if r.symmetry is not None:
            kinds.setdefault(r.symmetry.completion, []).append(mir7.get(r.view, math.nan))
    known = [r.symmetry for r in records if r.symmetry is not None]
    known = [p for p in known if math.isfinite(p.plane_error_deg) and math.isfinite(p.confidence)]
    bad = [p.plane_error_deg > 10 or p.plane_error_mm > 10 for p in known]
    conf = [p.confidence for p in known]
    return {
        "kinds": {k: {"n": len(v), "mir7_mm": _mean(v)} for k, v in sorted(kinds.items())},
        "n_known": len(known),
        "n_bad": int(sum(bad)),
        "confidence_auc": roc_auc(conf, bad) if known else math.nan,
        "vote_auc": roc_auc([-p.vote for p in known], bad) if known else math.nan,
    }


def _checks(s: dict[str, Any], methods: Sequence[str]) -> dict[str, Any]:
    """The paper's findings, each ``{"holds": bool | None, "detail": str}`` (None: not measured)."""
    checks: dict[str, Any] = {}
    per = s["per_orientation"]
    for m in ("Mir5", "Mir7"):
        if m not in methods or "Del" not in methods:
            continue
        worse = [
            g
            for g, v in per.items()
            if not (v[m]["dev_mean_mm"] < v["Del"]["dev_mean_mm"])  # NaN counts as not below
        ]
        measured = any(math.isfinite(v[m]["dev_mean_mm"]) for v in per.values())
        detail = "all orientations" if not worse else "not at " + ", ".join(worse) + " deg"
        checks[f"{m}_below_Del_every_orientation"] = {
            "holds": (not worse) if measured else None,
            "detail": detail if measured else "no ground truth",
        }
    if "Mir7" in methods:
        v = s["methods"]["Mir7"]["dev_mean_mm"]
        checks["Mir7_mean_at_most_7mm"] = {
            "holds": (v <= PAPER["mir7_mean_mm"]) if math.isfinite(v) else None,
            "detail": f"{v:.2f} mm" if math.isfinite(v) else "no ground truth",
        }
    for m in methods:
        if m == "Del":
            continue
        v = s["methods"][m]["centroid_error"]
        checks[f"{m}_centroid_at_most_10pct"] = {
            "holds": (v <= PAPER["centroid_max"]) if math.isfinite(v) else None,
            "detail": f"{100 * v:.1f} %" if math.isfinite(v) else "no ground truth",
        }
    return checks


def write_tables(
    out_dir: str | Path,
    rows: Sequence[dict[str, Any]],
    summary: dict[str, Any],
    config: dict[str, Any],
    info: dict[str, Any],
) -> tuple[Path, Path]:
    """Writes ``results.csv`` (one row per view and method) and ``results.json`` (rows, summary,
    configuration, run information), atomically."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(ROW_FIELDS), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    out = Path(out_dir)
    p_csv = atomic_write_text(out / "results.csv", buf.getvalue())
    p_json = atomic_write_json(
        out / "results.json",
        jsonable({"config": config, "run": info, "summary": summary, "rows": list(rows)}),
    )
    return p_csv, p_json


def _fmt(x: float, nd: int = 1, scale: float = 1.0) -> str:
    return "n/a" if not math.isfinite(x) else f"{x * scale:.{nd}f}"


def _yes(h: bool | None) -> str:
    return "n/a (not measured)" if h is None else ("**holds**" if h else "**does not hold**")


def write_report(
    out_dir: str | Path,
    summary: dict[str, Any],
    methods: Sequence[str],
    figures: dict[str, str],
    info: dict[str, Any],
    source: str,
    records: Sequence[ViewRecord] = (),
) -> Path:
    """Writes the one-page ``report.md``: summary table, per-orientation table, plane errors,
    timings, the paper's findings, the completion of each view in ``records`` and the figures
    (paths relative to the report)."""
    s = summary
    L: list[str] = [
        "# Mesh evaluation (Bohg et al. 2011, Section V-A and V-B)",
        "",
        f"Data: {source}; {s['n_views']} views. Methods: Del (Delaunay of the observed points),"
        " Mir5 / Mir7 (mirrored cloud, Poisson depth 5 / 7). Deviation: mean distance from"
        " uniform samples of the ground-truth surface to the mesh (MeshDev), averaged over views;"
        " centroid error: distance between surface centroids over the ground truth's"
        " oriented-box diagonal.",
        "",
        "## Summary",
        "",
        "| method | views | failed | mean deviation [mm] | variance [mm^2] | centroid error [%] |",
        "|---|---|---|---|---|---|",
    ]
    for m in methods:
        v = s["methods"][m]
        L.append(
            f"| {m} | {v['n']} | {v['n_failed']} | {_fmt(v['dev_mean_mm'], 2)} |"
            f" {_fmt(v['dev_var_mm2'], 1)} | {_fmt(v['centroid_error'], 1, 100)} |"
        )
    L += ["", "Mean deviation [mm] per orientation (Fig. 10):", ""]
    groups = list(s["per_orientation"])
    L.append("| method | " + " | ".join(f"{float(g):g} deg" for g in groups) + " |")
    L.append("|---" * (len(groups) + 1) + "|")
    for m in methods:
        vals = [_fmt(s["per_orientation"][g][m]["dev_mean_mm"], 1) for g in groups]
        L.append(f"| {m} | " + " | ".join(vals) + " |")
    L += ["", "Centroid error [% of box diagonal] per orientation (Fig. 12):", ""]
    L.append("| method | " + " | ".join(f"{float(g):g} deg" for g in groups) + " |")
    L.append("|---" * (len(groups) + 1) + "|")
    for m in methods:
        vals = [_fmt(s["per_orientation"][g][m]["centroid_error"], 1, 100) for g in groups]
        L.append(f"| {m} | " + " | ".join(vals) + " |")
    pe = s["plane_error"]
    L += [
        "",
        f"Symmetry plane error over the {pe['n']} views with a known plane: median"
        f" {_fmt(pe['median_deg'])} deg / {_fmt(pe['median_mm'])} mm, mean {_fmt(pe['mean_deg'])}"
        f" deg / {_fmt(pe['mean_mm'])} mm;"
        f" {_fmt(pe['frac_within_10deg_10mm'], 0, 100)} % within 10 deg and 10 mm.",
    ]
    L += _completion_lines(s["completion"])
    L += ["", "## The paper's findings", ""]
    names = {
        "Mir5_below_Del_every_orientation": "Mir5 deviates less than Del in every orientation",
        "Mir7_below_Del_every_orientation": "Mir7 deviates less than Del in every orientation",
        "Mir7_mean_at_most_7mm": "Mir7 mean deviation over all views is at most 7 mm",
        "Mir5_centroid_at_most_10pct": "Mir5 centroid error is at most 10 % on average",
        "Mir7_centroid_at_most_10pct": "Mir7 centroid error is at most 10 % on average",
    }
    for k, c in s["checks"].items():
        L.append(f"- {names.get(k, k)}: {_yes(c['holds'])} ({c['detail']}).")
    t = s["timings_s"]
    n = max(s["n_views"], 1)
    L += [
        "",
        "## Timings",
        "",
        f"This run: {info['run_s']:.0f} s wall ({info['n_computed']} views computed,"
        f" {info['n_resumed']} resumed; view selection and benchmark loading"
        f" {info['select_s']:.1f} s). Stage totals over all views (batched stages shared equally"
        " among the views of a batch; resumed views keep the times of their run):",
        "",
        "| stage | total [s] | per view [s] |",
        "|---|---|---|",
    ]
    for k, v in t.items():
        L.append(f"| {k} | {v:.1f} | {v / n:.3f} |")
    L += _per_view_lines(records) if records else []
    L += ["", "## Figures", ""]
    for title, rel in figures.items():
        L += [f"### {title}", "", f"![{title}]({rel})", ""]
    return atomic_write_text(Path(out_dir) / "report.md", "\n".join(L) + "\n")


def _completion_lines(c: dict[str, Any]) -> list[str]:
    kinds = ", ".join(
        f"{k} {v['n']} (Mir7 {_fmt(v['mir7_mm'], 2)} mm)" for k, v in c["kinds"].items()
    )
    return [
        "",
        "## Completion (beyond the paper)",
        "",
        f"Views by completion: {kinds or 'none'}. Revolution: the visible surface is a surface"
        " of revolution about the table normal; mirror: the plane of Eq. 4; fallback (a plane"
        " confidence below the threshold): the mirror across the near-best plane of the search"
        " that the view supports best, or the hull of the visible points and their table"
        " footprint (see each view's reason).",
        "",
        "Plane confidence (the plane's support, the paper's case i, its best rival's and the"
        f" axis residual of the visible surface): ROC AUC"
        f" {_fmt(c['confidence_auc'], 3)} at telling the {c['n_bad']} of {c['n_known']} planes"
        f" off by more than 10 deg or 10 mm from the rest (the vote of Eq. 3 alone:"
        f" {_fmt(c['vote_auc'], 3)}).",
    ]


def _per_view_lines(records: Sequence[ViewRecord]) -> list[str]:
    L = [
        "",
        "## Completion of each view",
        "",
        "| view | completion | confidence | plane error [deg / mm] | Mir7 [mm] | why |",
        "|---|---|---|---|---|---|",
    ]
    for r in sorted(records, key=lambda r: r.view):
        p = r.symmetry
        if p is None:
            L.append(f"| {r.view} | none | | | | symmetry search failed |")
            continue
        m7 = r.result("Mir7").dev_mean_mm if "Mir7" in r.methods else math.nan
        L.append(
            f"| {r.view} | {p.completion} | {_fmt(p.confidence, 2)} |"
            f" {_fmt(p.plane_error_deg)} / {_fmt(p.plane_error_mm)} | {_fmt(m7, 2)} |"
            f" {p.completion_reason} |"
        )
    return L
