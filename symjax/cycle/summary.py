"""The clear-table run's tables: per robot and mode the share of objects cleared, collisions,
stage times, the time from a frame to an executed pick, and why objects were not cleared."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from symjax._atomic import atomic_write_json, atomic_write_text
from symjax._timing import median_p95
from symjax.cycle.config import STAGES

__all__ = ["summarise", "write_report"]


def _median(x) -> float | None:
    return median_p95(x, 2)["median"]


def summarise(results: list[dict]) -> dict[str, Any]:
    """``{robot: {mode: row}}`` from the per-scene result dicts."""
    out: dict[str, Any] = {}
    failed: dict[tuple[str, str], int] = {}
    for d in results:
        if "error" in d:
            failed[d["robot"], d["mode"]] = failed.get((d["robot"], d["mode"]), 0) + 1
            continue
        out.setdefault(d["robot"], {}).setdefault(d["mode"], []).append(d)
    table: dict[str, Any] = {}
    for robot, modes in out.items():
        for mode, ds in modes.items():
            objs = [o for d in ds for o in d["objects"]]
            picks = [r for d in ds for r in d["rounds"] if r["execution"] is not None]
            reasons: dict[str, int] = {}
            for o in objs:
                if not o["cleared"]:
                    reasons[o["stage"]] = reasons.get(o["stage"], 0) + 1
            stage_s = {s: _median([r["seconds"][s] for r in picks if s in r["seconds"]])
                       for s in STAGES}  # fmt: skip
            table.setdefault(robot, {})[mode] = {
                "scenes": len(ds),
                "failed_scenes": failed.get((robot, mode), 0),
                "objects": len(objs),
                "cleared": sum(o["cleared"] for o in objs),
                "cleared_share": round(sum(o["cleared"] for o in objs) / max(len(objs), 1), 3),
                "picks": len(picks),
                "picks_delivered": sum(r["execution"]["delivered"] for r in picks),
                "picks_with_collision": sum(bool(r["execution"]["collisions"]) for r in picks),
                "knocked_off": sum(len(r["execution"]["knocked_off"]) for r in picks),
                "not_cleared_by_stage": dict(sorted(reasons.items(), key=lambda kv: -kv[1])),
                "pick_seconds_median": _median([r["total_seconds"] for r in picks]),
                "stage_seconds_median": stage_s,
                "scene_seconds_median": _median([d["seconds"] for d in ds]),
            }
    return table


def write_report(results: list[dict], out_dir: Any, command: str = "") -> dict[str, Path]:
    """Writes ``results.json`` and ``report.md`` under ``out_dir``; returns their paths."""
    out = Path(out_dir)
    table = summarise(results)
    paths = {"results": atomic_write_json(out / "results.json", {"summary": table})}
    lines = ["# Grasp cycle (paper Algorithm 1) on seeded table scenes", ""]
    if command:
        lines += [f"`{command}`", ""]
    lines += ["| robot | mode | scenes | objects | cleared | picks | delivered | collisions |"
              " knocked off | s per pick (median) |",
              "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for robot, modes in sorted(table.items()):
        for mode in ("C", "K", "P", "T"):
            if mode in modes:
                r = modes[mode]
                lines.append(
                    f"| {robot} | {mode} | {r['scenes']} | {r['objects']} |"
                    f" {r['cleared']} ({100 * r['cleared_share']:.1f} %) | {r['picks']} |"
                    f" {r['picks_delivered']} | {r['picks_with_collision']} | {r['knocked_off']}"
                    f" | {r['pick_seconds_median']} |"
                )
    lines += ["", "C: completed by symmetry (Mir7); K: the completion's plausible shapes, grasps"
              " ranked across them; P: the observed points alone (Delaunay);"
              " T: the true meshes (oracle).", "", "## Stage times of a pick (median, s)", "",
              "| robot | mode | " + " | ".join(STAGES) + " |",
              "|---|---|" + "---|" * len(STAGES)]  # fmt: skip
    for robot, modes in sorted(table.items()):
        for mode, r in sorted(modes.items()):
            lines.append(
                f"| {robot} | {mode} | "
                + " | ".join(str(r["stage_seconds_median"][s]) for s in STAGES)
                + " |"
            )
    lines += ["", "## Objects not cleared, by the stage they stopped at", ""]
    for robot, modes in sorted(table.items()):
        for mode, r in sorted(modes.items()):
            lines.append(f"- {robot} {mode}: " + (", ".join(
                f"{k} {v}" for k, v in r["not_cleared_by_stage"].items()) or "none"))  # fmt: skip
    pics = sorted({d["picture"] for d in results if d.get("picture")})
    if pics:
        lines += ["", "## Pictures", "", "Head-camera frame with the hypotheses, then the pick in"
                  " C MuJoCo with the completed shapes as points: pre-grasp, grasp, lift,"
                  " release.", ""]  # fmt: skip
        lines += [f"![{p}]({p})" for p in pics]
    paths["report"] = atomic_write_text(out / "report.md", "\n".join(lines) + "\n")
    return paths
