"""``symjax clear-table``: the paper's grasp cycle (Algorithm 1) on seeded table scenes of YCB
scans (preset ``cycle`` unless --config names another), for each robot, three ways in the same
run: with the completion (C), the observed points alone (P) and the true meshes (T). Writes
under --out-dir: scenes/<robot>_<seed>_<mode>.json (one file per scene and mode, written
atomically; a rerun with the same settings resumes), pictures/*.png, results.json, report.md.
"""

from __future__ import annotations

import dataclasses
import os
import sys
from typing import Literal

os.environ.setdefault("MUJOCO_GL", "egl")  # the pictures' offscreen renderer, before MuJoCo loads

from symjax.cli.common import PresetArgs, parse, run  # noqa: E402

__all__ = ["ClearTableCommand", "main"]


@dataclasses.dataclass(frozen=True)
class ClearTableCommand(PresetArgs):
    """Runs the grasp cycle on seeded table scenes.

    Attributes:
        config: Preset name or TOML path (default ``cycle``, the cycle's own).
        robots: Robots to run (kth, uji).
        scenes: Seeded scenes per robot.
        modes: Ways to run each scene: C completion, P observed points, T true meshes; K (not
            by default) the completion's plausible shapes, grasps ranked across them.
        min_objects: Fewest objects in a scene (1-6).
        max_objects: Most objects in a scene (1-6); the counts cycle from min to max.
        seed: Seed of the first scene (scene s has seed + s).
        out_dir: Output folder.
        pictures: Scenes per robot whose C run gets a picture.
        backend: Grasp rollout backend (mujoco, mjx, mjx_warp; default by device).
    """

    config: str = "cycle"
    robots: tuple[Literal["kth", "uji"], ...] = ("kth", "uji")
    scenes: int = 20
    modes: tuple[Literal["C", "K", "P", "T"], ...] = ("C", "P", "T")
    min_objects: int = 2
    max_objects: int = 5
    seed: int = 0
    out_dir: str = "out/clear_table"
    pictures: int = 2
    backend: Literal["mujoco", "mjx", "mjx_warp"] | None = None


def _body(argv: list[str]) -> int:
    from symjax import configs
    from symjax.cycle import CycleConfig
    from symjax.cycle.batch import run_scenes, scene_specs
    from symjax.cycle.summary import write_report

    args = parse(ClearTableCommand, argv, "symjax clear-table", __doc__)
    base = CycleConfig.from_preset(configs.load(args.config), backend=args.backend)
    specs = scene_specs(args.robots, args.scenes, args.seed, (args.min_objects, args.max_objects))
    results = run_scenes(specs, args.modes, base, args.out_dir, pictures=args.pictures,
                         progress=lambda s: print(s, flush=True))  # fmt: skip
    paths = write_report(results, args.out_dir, "symjax clear-table " + " ".join(argv))
    print(paths["report"].read_text())
    return 0


def main(argv: list[str] | None = None, prog: str = "symjax clear-table") -> int:
    """Command line entry point; returns the exit status (0 ok, 2 bad arguments or data)."""
    return run(prog, _body, sys.argv[1:] if argv is None else argv)
