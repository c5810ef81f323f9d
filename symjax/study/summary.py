"""The study's tables and figure: success on the truth per hand and planning mesh (overall, per
object, per orientation), the gaps T-C and T-P, and the planner's predicted success against the
success on the truth (calibration)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from symjax._atomic import atomic_write_bytes, atomic_write_json, atomic_write_text
from symjax.study.config import PLANNING_MESHES

__all__ = ["summarise", "write_report"]


def _rates(rows: list[dict], top: int) -> dict[str, Any]:
    """Success on the truth over ``top`` grasps per view (a view without a plan scores 0)."""
    truth = sum(sum(r["truth"]) for r in rows)
    n_grasps = sum(len(r["truth"]) for r in rows)
    pred = sum(sum(r["predicted"]) for r in rows)
    return {
        "views": len(rows),
        "no_plan": sum(not r["truth"] for r in rows),
        "success": round(100 * truth / max(top * len(rows), 1), 2),
        "success_of_planned": round(100 * truth / max(n_grasps, 1), 2),
        "predicted": round(100 * pred / max(n_grasps, 1), 2),
    }


def summarise(records: list[dict], top: int) -> dict[str, Any]:
    """``{"hands": {hand: {mesh: rates, "T-C", "T-P"}}, "by_object", "by_orientation"}``."""
    good = [r for r in records if r.get("hands")]
    hands = sorted({h for r in good for h in r["hands"]})
    out: dict[str, Any] = {"views": len(good), "failed_views": len(records) - len(good),
                           "hands": {}, "by_object": {}, "by_orientation": {}}  # fmt: skip
    for h in hands:
        per = {k: _rates([r["hands"][h][k] for r in good if h in r["hands"]], top)
               for k in PLANNING_MESHES}  # fmt: skip
        per["T-C"] = round(per["T"]["success"] - per["C"]["success"], 2)
        per["T-P"] = round(per["T"]["success"] - per["P"]["success"], 2)
        out["hands"][h] = per
        for group, field in (("by_object", "object"), ("by_orientation", "orientation_deg")):
            keys = sorted({str(r[field]) for r in good})
            out[group][h] = {key: {k: _rates([r["hands"][h][k] for r in good
                                              if str(r[field]) == key and h in r["hands"]],
                                             top)["success"] for k in PLANNING_MESHES}
                             for key in keys}  # fmt: skip
    return out


def _figure(summary: dict, path: Path) -> None:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hands = list(summary["hands"])
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    w = 0.25
    for j, k in enumerate(PLANNING_MESHES):
        ax[0].bar(np.arange(len(hands)) + (j - 1) * w,
                  [summary["hands"][h][k]["success"] for h in hands], w, label=k)  # fmt: skip
    ax[0].set_xticks(np.arange(len(hands)), hands)
    ax[0].set_ylabel("success on the true object, % of top grasps")
    ax[0].set_ylim(0, 100)
    ax[0].legend(title="planned on")
    for k, mk in zip(PLANNING_MESHES, "os^", strict=True):
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
              "| hand | T | C | P | T-C | T-P | predicted on C | no plan C / P |",
              "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for h, r in s["hands"].items():
        lines.append(f"| {h} | {r['T']['success']} | {r['C']['success']} | {r['P']['success']} |"
                     f" {r['T-C']} | {r['T-P']} | {r['C']['predicted']} |"
                     f" {r['C']['no_plan']} / {r['P']['no_plan']} |")  # fmt: skip
    lines += ["", "Success in % of the top grasps (a view without a plan counts 0).", "",
              "![study](study.png)", ""]  # fmt: skip
    for group in ("by_object", "by_orientation"):
        lines += [f"## Success on the truth {group.replace('_', ' ')}", ""]
        for h, table in s[group].items():
            lines += [f"| {h} | T | C | P |", "|---|---|---|---|"]
            lines += [f"| {k} | {v['T']} | {v['C']} | {v['P']} |" for k, v in table.items()]
            lines.append("")
    atomic_write_text(out / "report.md", "\n".join(lines) + "\n")
    return s
