"""``symjax study``: plan on the completion, score on the truth. For every view (the embedded
128 views and views of other scans) and hand, grasps are planned on the true mesh (T), the
completion (C, Mir7) and the observed points alone (P, the Delaunay baseline); the top grasps of
each are rolled out on the true object. Writes under --out-dir: views/*.json (one per view; a
rerun resumes), results.json, study.png and report.md. Preset ``study`` unless --config names
another.
"""

from __future__ import annotations

import dataclasses
import sys
from typing import Annotated, Literal

import tyro

from symjax.cli.common import PresetArgs, parse, run

__all__ = ["StudyCommand", "main"]


@dataclasses.dataclass(frozen=True)
class StudyCommand(PresetArgs):
    """Runs the study.

    Attributes:
        config: Preset name or TOML path (default ``study``, the study's own).
        out_dir: Output folder.
        top: Grasps of each planning mesh rolled out on the truth.
        subset: Benchmark subset items (data set ids, view names); empty = all 128 views.
        extra_scans: Other scans to add views of (none: the benchmark alone).
        backend: Rollout backend (mujoco, mjx, mjx_warp; default by device).
    """

    config: str = "study"
    out_dir: str = "out/study"
    top: int = 5
    subset: tuple[str, ...] = ()
    extra_scans: Annotated[tuple[str, ...], tyro.conf.arg(name="extra-scans")] = (
        "002_master_chef_can", "010_potted_meat_can", "013_apple", "024_bowl")  # fmt: skip
    backend: Literal["mujoco", "mjx", "mjx_warp"] | None = None


def _body(argv: list[str]) -> int:
    from symjax import configs
    from symjax.study import StudyConfig, run_study, write_report

    args = parse(StudyCommand, argv, "symjax study", __doc__)
    cfg = StudyConfig.from_preset(configs.load(args.config), out_dir=args.out_dir, top=args.top,
                                  subset=args.subset, extra_scans=args.extra_scans,
                                  backend=args.backend)  # fmt: skip
    records = run_study(cfg, log=lambda s: print(s, flush=True))
    s = write_report(records, cfg.out_dir, cfg.top, "symjax study " + " ".join(argv))
    for h, r in s["hands"].items():
        print(f"{h}: T {r['T']['success']} %, C {r['C']['success']} %, P {r['P']['success']} %,"
              f" T-C {r['T-C']}, T-P {r['T-P']}")  # fmt: skip
    print(f"report: {cfg.out_dir}/report.md")
    return 0


def main(argv: list[str] | None = None, prog: str = "symjax study") -> int:
    """Command line entry point; returns the exit status (0 ok, 2 bad arguments or data)."""
    return run(prog, _body, sys.argv[1:] if argv is None else argv)
