"""The study's tables and figure: success on the truth per hand and planning mesh (overall, per
object, per orientation), the gaps T-C and T-P, and the planner's predicted success against the
success on the truth (calibration)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from symjax._atomic import atomic_write_bytes, atomic_write_json, atomic_write_text
from symjax.study.config import PLANNING_MESHES

__all__ = ["prediction_intervals", "summarise", "write_report"]


def _rates(rows: list[dict], top: int) -> dict[str, Any]:
    """Success on the truth over ``top`` grasps per view (a view without a plan scores 0)."""
    truth = sum(sum(r["truth"]) for r in rows)
    n_grasps = sum(len(r["truth"]) for r in rows)
    pred = sum(sum(r["predicted"]) for r in rows)
    secs = [r["seconds"] for r in rows if "seconds" in r]
    out = {
        "views": len(rows),
        "no_plan": sum(not r["truth"] for r in rows),
        "success": round(100 * truth / max(top * len(rows), 1), 2),
        "success_of_planned": round(100 * truth / max(n_grasps, 1), 2),
        "predicted": round(100 * pred / max(n_grasps, 1), 2),
    }
    # How far the planner's own prediction is from the truth, on the grasps it chose.
    out["overconfidence"] = round(out["predicted"] - out["success_of_planned"], 2)
    pairs = [(p, float(t)) for r in rows for p, t in zip(r["predicted"], r["truth"], strict=True)]
    if pairs:
        # The signed gap lets over- and under-confident views cancel; the Brier score does not.
        out["brier"] = round(float(np.mean([(p - t) ** 2 for p, t in pairs])), 4)
    if secs:
        out["seconds_median"] = round(float(np.median(secs)), 3)
    return out


def _view_sums(rows: list[dict]) -> np.ndarray:
    """(V, 3) per view: sum of predicted success, sum of success on the truth, grasps."""
    return np.array([[sum(r["predicted"]), sum(r["truth"]), len(r["truth"])] for r in rows], float)


def _gap(sums: np.ndarray) -> np.ndarray:
    """Over-confidence (percentage points) of view sums (..., V, 3)."""
    s = sums.sum(axis=-2)
    return 100.0 * (s[..., 0] - s[..., 1]) / np.maximum(s[..., 2], 1.0)


def prediction_intervals(per_mesh: dict[str, list[dict]], resamples: int = 2000,
                         seed: int = 0) -> dict[str, Any]:  # fmt: skip
    """95 % bootstrap intervals (views resampled with replacement) of each mesh's
    over-confidence, and for ``K`` against ``C`` of the change of its size.

    Args:
        per_mesh: ``{mesh: [row of one view]}``, the rows of the same views in the same order.
        resamples: Bootstrap resamples.
        seed: Seed of the resampling (the report is reproducible).

    Returns:
        ``{mesh: [low, high]}`` and, with ``C`` and ``K``, ``"K_vs_C"``: ``{"abs_gap_change"
        (|K| - |C|, points), "interval", "share_K_closer"}`` (the share of resamples in which
        K's prediction is the closer one).
    """
    keys = [k for k, rows in per_mesh.items() if rows]
    if not keys:
        return {}
    n = len(per_mesh[keys[0]])
    idx = np.random.default_rng(seed).integers(0, n, (resamples, n))
    boot = {k: _gap(_view_sums(per_mesh[k])[idx]) for k in keys}
    out: dict[str, Any] = {k: [round(float(x), 2) for x in np.percentile(b, [2.5, 97.5])]
                           for k, b in boot.items()}  # fmt: skip
    if "C" in boot and "K" in boot:
        full = {k: float(_gap(_view_sums(per_mesh[k]))) for k in ("C", "K")}
        d = np.abs(boot["K"]) - np.abs(boot["C"])
        out["K_vs_C"] = {
            "abs_gap_change": round(abs(full["K"]) - abs(full["C"]), 2),
            "interval": [round(float(x), 2) for x in np.percentile(d, [2.5, 97.5])],
            "share_K_closer": round(float(np.mean(d < 0)), 3),
        }
    return out


def _meshes(records: list[dict], hand: str) -> list[str]:
    """The planning meshes every record of the hand has, in PLANNING_MESHES order."""
    have = [set(r["hands"][hand]) for r in records if hand in r["hands"]]
    return [k for k in PLANNING_MESHES if have and all(k in h for h in have)]


def summarise(records: list[dict], top: int) -> dict[str, Any]:
    """``{"hands": {hand: {mesh: rates, "T-C", "T-P"[, "T-K", "K_extra_seconds_median"]}},
    "by_object", "by_orientation"}``."""
    good = [r for r in records if r.get("hands")]
    hands = sorted({h for r in good for h in r["hands"]})
    out: dict[str, Any] = {"views": len(good), "failed_views": len(records) - len(good),
                           "hands": {}, "by_object": {}, "by_orientation": {}}  # fmt: skip
    for h in hands:
        keys = _meshes(good, h)
        per = {k: _rates([r["hands"][h][k] for r in good if h in r["hands"]], top) for k in keys}
        for k in ("C", "K", "P"):
            if k in per:
                per[f"T-{k}"] = round(per["T"]["success"] - per[k]["success"], 2)
        if "K" in per:
            # K's planning beyond C's: the other shapes' decompositions and rollouts (its plan
            # repeats C's rollouts on the first shape; C's own decomposition is shared).
            extra = [r["hands"][h]["K"]["seconds"] - r["hands"][h]["C"]["seconds"]
                     + r["hands"][h]["C"].get("decompose_seconds", 0.0)
                     for r in good if h in r["hands"] and "seconds" in r["hands"][h]["K"]
                     and "seconds" in r["hands"][h]["C"]]  # fmt: skip
            if extra:
                per["K_extra_seconds_median"] = round(float(np.median(extra)), 3)
        per["overconfidence_ci95"] = prediction_intervals(
            {k: [r["hands"][h][k] for r in good if h in r["hands"]] for k in keys if k != "T"}
        )
        out["hands"][h] = per
        for group, field in (("by_object", "object"), ("by_orientation", "orientation_deg")):
            groups = sorted({str(r[field]) for r in good})
            out[group][h] = {key: {k: _rates([r["hands"][h][k] for r in good
                                              if str(r[field]) == key and h in r["hands"]],
                                             top)["success"] for k in keys}
                             for key in groups}  # fmt: skip
    return out


def _figure(summary: dict, path: Path) -> None:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hands = list(summary["hands"])
    keys = [k for k in PLANNING_MESHES if all(k in summary["hands"][h] for h in hands)]
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    w = 0.8 / len(keys)
    for j, k in enumerate(keys):
        ax[0].bar(np.arange(len(hands)) + (j - (len(keys) - 1) / 2) * w,
                  [summary["hands"][h][k]["success"] for h in hands], w, label=k)  # fmt: skip
    ax[0].set_xticks(np.arange(len(hands)), hands)
    ax[0].set_ylabel("success on the true object, % of top grasps")
    ax[0].set_ylim(0, 100)
    ax[0].legend(title="planned on")
    for k, mk in zip(keys, "osD^", strict=False):
        for h in hands:
            r = summary["hands"][h][k]
            ax[1].scatter(r["predicted"], r["success_of_planned"], marker=mk, s=60,
                          label=f"{h} {k}")  # fmt: skip
    ax[1].plot([0, 100], [0, 100], "k--", lw=1)
    ax[1].set_xlabel("predicted success on the planning mesh, %")
    ax[1].set_ylabel("success on the true object, %")
    ax[1].set_xlim(0, 105)
    ax[1].set_ylim(0, 105)
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def _prediction_lines(s: dict) -> list[str]:
    """The report's section on the planner's prediction of its own success."""
    lines = ["## The planner's prediction of success", "",
             "| hand | mesh | predicted | held on the truth | over-confidence [95 % interval] |"
             " Brier score |", "|---|---|---|---|---|---|"]  # fmt: skip
    for h, r in s["hands"].items():
        ci = r.get("overconfidence_ci95", {})
        for k in (k for k in PLANNING_MESHES if k != "T" and k in r):
            lo, hi = ci.get(k, ["-", "-"])
            m = r[k]
            lines.append(
                f"| {h} | {k} | {m['predicted']} | {m['success_of_planned']} |"
                f" {m['overconfidence']} [{lo}, {hi}] | {m.get('brier', '-')} |"
            )
    lines += ["", "Over-confidence: predicted minus held, points; its interval resamples the"
              " views (bootstrap). The Brier score is the mean squared difference per grasp, so"
              " over- and under-confident views do not cancel in it."]  # fmt: skip
    for h, r in s["hands"].items():
        kc = r.get("overconfidence_ci95", {}).get("K_vs_C")
        if kc:
            lines.append(f"{h}: |over-confidence| of K minus C {kc['abs_gap_change']} points"
                         f" [{kc['interval'][0]}, {kc['interval'][1]}]; K closer in"
                         f" {100 * kc['share_K_closer']:.0f} % of the resamples.")  # fmt: skip
    return lines + [""]


def write_report(records: list[dict], out_dir: Any, top: int, command: str = "") -> dict:
    """Writes ``results.json``, ``study.png`` and ``report.md``; returns the summary."""
    out = Path(out_dir)
    s = summarise(records, top)
    atomic_write_json(out / "results.json", s)
    _figure(s, out / "study.png")
    lines = ["# Study: plan on the completion, score on the truth", ""]
    if command:
        lines += [f"`{command}`", ""]
    lines += [f"{s['views']} views ({s['failed_views']} failed); top {top} grasps of each"
              " planning mesh rolled out on the true object.", "",
              "| hand | T | C | K | P | T-C | T-K | T-P | predicted on C / K | no plan C / P |"
              " K's extra planning time (median) |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for h, r in s["hands"].items():
        k = r.get("K", {})
        lines.append(f"| {h} | {r['T']['success']} | {r['C']['success']} |"
                     f" {k.get('success', '-')} | {r['P']['success']} | {r['T-C']} |"
                     f" {r.get('T-K', '-')} | {r['T-P']} | {r['C']['predicted']} /"
                     f" {k.get('predicted', '-')} | {r['C']['no_plan']} / {r['P']['no_plan']} |"
                     f" {r.get('K_extra_seconds_median', '-')} s |")  # fmt: skip
    lines += ["", "Success in % of the top grasps (a view without a plan counts 0). K: the"
              " completion's plausible shapes, each grasp ranked by its success across them"
              " (predicted: the weighted mean over the shapes).", "",
              "![study](study.png)", ""]  # fmt: skip
    lines += _prediction_lines(s)
    for group in ("by_object", "by_orientation"):
        lines += [f"## Success on the truth {group.replace('_', ' ')}", ""]
        for h, table in s[group].items():
            cols = list(next(iter(table.values())))
            lines += [f"| {h} | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
            lines += [f"| {k} | " + " | ".join(str(v[c]) for c in cols) + " |"
                      for k, v in table.items()]  # fmt: skip
            lines.append("")
    atomic_write_text(out / "report.md", "\n".join(lines) + "\n")
    return s
