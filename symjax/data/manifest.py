"""The data set's manifest: one row per complete shard, rebuilt from the shard files themselves
(each keeps its row as an attribute), so that a merge after many workers, a crash or a rerun
counts every shard exactly once."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from symjax._atomic import atomic_write_json
from symjax.data.acronym_file import shard_status

__all__ = ["collect_manifest", "write_manifest"]


def collect_manifest(out_dir: Path, keys: dict[Path, str]) -> list[dict[str, Any]]:
    """The rows of the complete shards among ``keys`` (``{path: shard key}``), in that order."""
    import h5py

    rows = []
    for path, key in keys.items():
        if shard_status(path, key) != "complete":
            continue
        with h5py.File(path, "r") as f:
            rows.append(json.loads(f.attrs["symjax_manifest_row"]))
    return rows


def write_manifest(out_dir: Path, rows: list[dict[str, Any]], expected: int,
                   extra: dict[str, Any]) -> dict[str, Any]:  # fmt: skip
    """Writes ``manifest.json`` atomically: the shards, per-hand totals and the run's details."""
    hands: dict[str, dict[str, Any]] = {}
    for r in rows:
        h = hands.setdefault(r["hand"], {"shards": 0, "grasps": 0, "success": 0})
        h["shards"] += 1
        h["grasps"] += r["n_grasps"]
        h["success"] += r["n_success"]
    for h in hands.values():
        h["success_rate"] = round(h["success"] / max(h["grasps"], 1), 4)
    doc = {
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "complete": len(rows) == expected,
        "n_shards": len(rows),
        "expected_shards": expected,
        "hands": hands,
        **extra,
        "shards": rows,
    }
    atomic_write_json(Path(out_dir) / "manifest.json", doc)
    return doc
