"""The paper's mesh evaluation (Bohg et al. 2011, Section V-A/V-B) with figures and a report.

For every view: symmetry search on the observation, Poisson meshes of the completed cloud at
depth 5 (Mir5) and 7 (Mir7), the Delaunay baseline of the observed points (Del), and each mesh
against the ground truth (mean/variance of the deviation, centroid error over the oriented-box
diagonal), plus the symmetry plane error and per-stage timings. Writes under --out:

  views/*.json        one file per view (resume: views already there are skipped)
  results.csv/.json   one row per view and method; summary and configuration
  fig10_orientation.png, fig11_objects.png, fig12_centroid.png, gallery.png
  report.md           summary table, the paper's findings, timings, figures

Default data: the embedded 128-view benchmark (generated into the cache on first use).
--data DIR evaluates a folder in the paper's KTH database layout (no ground truth there:
deviation, centroid and plane errors are left empty).

--subset takes comma-separated items, combined as: data sets / views (any of), orientations
(any of), then a count:
  025_mug                  a data set id (all its 8 orientations)
  025_mug/045              one view
  90deg                    one orientation of every selected data set
  4                        the first N selected views
e.g. --subset 4, --subset 025_mug,003_cracker_box, --subset 0deg,180deg,10.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


class _ArgError(Exception):
    """argparse error, raised instead of argparse's exit so main() returns a status."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # noqa: D102 - argparse hook
        raise _ArgError(message)


def _parser() -> argparse.ArgumentParser:
    from symjax.evaluation import METHODS

    ap = _Parser(
        prog="eval_dataset.py",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--out", default="out/eval", help="output folder (default: out/eval)")
    ap.add_argument(
        "--data",
        default=None,
        help="folder in the KTH database layout (segment_<deg>.crd, viewPoint_<deg>.txt,"
        " calib.txt); default: the embedded benchmark",
    )
    ap.add_argument(
        "--subset",
        default="",
        help="comma-separated: data set ids, view names, <deg>deg, a count N (see above)",
    )
    ap.add_argument(
        "--methods",
        default=",".join(METHODS),
        help=f"comma-separated subset of {','.join(METHODS)} (default: all)",
    )
    ap.add_argument(
        "--batch-size", type=int, default=16, help="views per jitted batch (default: 16)"
    )
    ap.add_argument(
        "--samples",
        type=int,
        default=5000,
        help="uniform ground-truth surface samples per metric (default: 5000)",
    )
    ap.add_argument("--gallery", type=int, default=4, help="views in gallery.png (0: none)")
    ap.add_argument("--seed", type=int, default=0, help="benchmark rendering seed (default: 0)")
    ap.add_argument("--cache-dir", default=None, help="benchmark cache folder")
    ap.add_argument(
        "--no-resume", action="store_true", help="recompute views already in --out/views"
    )
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    g = ap.add_argument_group("symmetry search (default: symjax's search, see SymmetryConfig)")
    g.add_argument(
        "--paper-search",
        action="store_true",
        help="the paper's exact search: Eq. 1 axis only, n x m grid, no refinement",
    )
    g.add_argument("--n-angles", type=int, default=None, help="plane orientations per level")
    g.add_argument("--n-shifts", type=int, default=None, help="plane shifts per level")
    g.add_argument("--n-refine", type=int, default=None, help="coarse-to-fine refinement levels")
    g.add_argument(
        "--angle-range-deg", type=float, default=None, help="orientation half-range, degrees"
    )
    return ap


def _config(args):
    import dataclasses
    import math

    from symjax.errors import ConfigError
    from symjax.evaluation import EvalConfig
    from symjax.symmetry import SymmetryConfig

    sym = SymmetryConfig(init="eigen", n_refine=0) if args.paper_search else SymmetryConfig()
    changes = {}
    for name in ("n_angles", "n_shifts", "n_refine"):
        value = getattr(args, name)
        if value is not None:
            changes[name] = value
    if args.angle_range_deg is not None:
        changes["angle_range"] = math.radians(args.angle_range_deg)
    if changes:
        sym = dataclasses.replace(sym, **changes)
    methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    subset = tuple(s.strip() for s in args.subset.split(",")) if args.subset.strip() else ()
    if args.data is not None and not args.data.strip():
        raise ConfigError("--data is empty; expected a folder")
    return EvalConfig(
        out_dir=args.out,
        methods=methods,
        subset=subset,
        data=args.data,
        cache_dir=args.cache_dir,
        seed=args.seed,
        batch_size=args.batch_size,
        n_samples=args.samples,
        symmetry=sym,
        gallery=args.gallery,
        resume=not args.no_resume,
        progress=not args.quiet,
    )


def main(argv: list[str] | None = None) -> int:
    """Command line entry point; returns the exit status (0 ok, 2 bad arguments or data)."""
    sys.path.insert(0, str(ROOT))
    from symjax.errors import SymjaxError

    ap = _parser()
    try:
        args = ap.parse_args(argv)
        cfg = _config(args)
    except SystemExit as e:  # --help
        return int(e.code or 0)
    except _ArgError as e:
        print(f"eval_dataset.py: error: {e} (see --help)", file=sys.stderr)
        return 2
    except SymjaxError as e:
        print(f"eval_dataset.py: error: {e}", file=sys.stderr)
        return 2

    from symjax.evaluation import run_evaluation

    t0 = time.perf_counter()
    try:
        out = run_evaluation(cfg)
    except SymjaxError as e:
        print(f"eval_dataset.py: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(
            "eval_dataset.py: interrupted; finished views are kept, run again to resume",
            file=sys.stderr,
        )
        return 130
    s = out["summary"]
    for m in cfg.methods:
        v = s["methods"][m]
        if math.isfinite(v["dev_mean_mm"]):
            print(
                f"{m:5s} mean deviation {v['dev_mean_mm']:.2f} mm, centroid error"
                f" {100 * v['centroid_error']:.1f} %, failed {v['n_failed']}/{v['n']}"
            )
        else:
            print(f"{m:5s} no ground truth, failed {v['n_failed']}/{v['n']}")
    for k, c in s["checks"].items():
        state = "n/a" if c["holds"] is None else ("holds" if c["holds"] else "DOES NOT HOLD")
        print(f"  {k}: {state} ({c['detail']})")
    print(f"done in {time.perf_counter() - t0:.0f} s; report: {out['files']['report']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
