"""Many seeded scenes through the cycle, each way (C, P, T): one JSON file per scene and mode,
written atomically, so that a rerun with the same settings resumes where the last one stopped."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from pathlib import Path
from typing import Any

from symjax._atomic import atomic_write_json
from symjax.cycle.config import CycleConfig
from symjax.errors import FileFormatError, InvalidInputError, SymjaxError

__all__ = ["SceneSpec", "run_scenes", "scene_specs"]

#: Bumped when a result file's meaning changes (older files are then redone).
RESULT_VERSION = 1


@dataclasses.dataclass(frozen=True)
class SceneSpec:
    """One seeded scene: ``robot``, ``seed``, ``n_objects``."""

    robot: str
    seed: int
    n_objects: int

    @property
    def name(self) -> str:
        return f"{self.robot}_{self.seed:04d}"


def scene_specs(robots: tuple[str, ...], n: int, seed: int, objects: tuple[int, int]) -> list:
    """``n`` scenes per robot, their object counts cycling through ``objects`` (min, max)."""
    lo, hi = objects
    if not (isinstance(n, int) and n >= 1) or not 1 <= lo <= hi <= 6:
        raise InvalidInputError(
            f"need >= 1 scenes and 1 <= min objects <= max objects <= 6, got {n}, {objects}"
        )
    return [SceneSpec(r, seed + s, lo + s % (hi - lo + 1)) for r in robots for s in range(n)]


def _key(spec: SceneSpec, cfg: CycleConfig) -> str:
    blob = json.dumps([RESULT_VERSION, dataclasses.asdict(spec), dataclasses.asdict(cfg)],
                      sort_keys=True)  # fmt: skip
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _done(path: Path, key: str) -> dict | None:
    if not path.is_file():
        return None
    try:
        d = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None  # a damaged file is redone
    return d if d.get("key") == key else None


def run_scenes(specs: list, modes: tuple[str, ...], base: CycleConfig, out_dir: Any,
               pictures: int = 0, progress: Any = print) -> list[dict]:  # fmt: skip
    """Runs every scene in every mode; returns the result dicts (read back when done before).

    Args:
        specs: :class:`SceneSpec` list.
        modes: Subset of :data:`symjax.cycle.MODES`.
        base: The cycle config (its mode is replaced by each of ``modes``).
        out_dir: Folder; files go to ``scenes/<robot>_<seed>_<mode>.json``.
        pictures: The first this many scenes of each robot in mode C also get pictures
            (``pictures/<robot>_<seed>.png``).
        progress: Called with one line per finished scene.
    """
    from symjax.cycle.grasp_cycle import clear_table
    from symjax.datasets import scan_scene

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise FileFormatError(f"out_dir {str(out)!r} is a file; expected a folder")
    results, pictured = [], {}
    for spec in specs:
        scene = None
        for mode in modes:
            cfg = dataclasses.replace(base, mode=mode)
            path = out / "scenes" / f"{spec.name}_{mode}.json"
            key = _key(spec, cfg)
            want_pic = mode == "C" and pictured.get(spec.robot, 0) < pictures
            pic_path = out / "pictures" / f"{spec.name}.png"
            if want_pic:
                pictured[spec.robot] = pictured.get(spec.robot, 0) + 1
            d = _done(path, key)
            if d is not None and (not want_pic or pic_path.is_file()):
                results.append(d)
                continue
            if scene is None:
                scene = scan_scene(spec.robot, spec.n_objects, seed=spec.seed)
            t0 = time.perf_counter()
            head = {"key": key, "scene": dataclasses.asdict(spec), "names": list(scene.names)}
            try:
                rep = clear_table(scene, spec.robot, cfg, pictures=want_pic)
            except SymjaxError as e:  # this scene fails, the run goes on
                d = {**head, "robot": spec.robot, "mode": mode, "error": f"{type(e).__name__}: {e}"}
                atomic_write_json(path, d)
                results.append(d)
                progress(f"{spec.name} {mode}: failed: {d['error'][:200]}")
                continue
            d = {**head, **rep.to_dict()}
            if want_pic:
                from symjax.cycle.pictures import cycle_picture

                cycle_picture(rep, pic_path)
                d["picture"] = str(pic_path.relative_to(out))
            atomic_write_json(path, d)
            results.append(d)
            progress(f"{spec.name} {mode}: cleared {d['n_cleared']}/{d['n_objects']},"
                     f" {d['collisions']} collisions, stop '{d['stop']}',"
                     f" {time.perf_counter() - t0:.0f} s")  # fmt: skip
    return results
