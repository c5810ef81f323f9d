"""How work is split and run: settings that change speed and memory, never results.

Kept apart from the numeric configurations so that caches, resume keys and result files depend
on the numbers alone: two runs that differ only here produce the same results.
"""

from __future__ import annotations

import dataclasses

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["ExecutionConfig"]


def _int_at_least(name: str, value: object, low: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ConfigError(f"{name} must be an integer >= {low}, got {value!r}")


@dataclasses.dataclass(frozen=True)
class ExecutionConfig:
    """Batching, chunking and threading of the jitted and simulated stages.

    Attributes:
        symmetry_chunk_views: Views scored at once by :func:`symjax.symmetry.search_batch`
            (0 = all of a point bucket). 1: one view a call, the single-view kernel, several
            views side by side in threads (one per core, at most 8); the fastest on a CPU
            (32 benchmark views: 23 ms a view against 33 ms vmapped 2 at a time, 2-core CPU,
            before the threads).
            A GPU wants many (16-128): a batch's views are grouped by point bucket and every
            group padded to this width.
        symmetry_chunk_hypotheses: Planes of one view scored at once (bounds the per-point
            intermediates; 0 = all). A chunk larger than a search level's planes (70 at
            level 0, 140 per refinement level of the default search) scores the level in
            one pass: on a 2-core CPU 256 ran the default search in 57 ms, 64 in 69 ms.
        poisson_chunk_views: Views solved at once by the batched Poisson solver (0 = all).
            1 (the default, for a CPU): the single-view kernel, several views side by side in
            threads (one per core, at most 8), each meshed as soon as it is solved. >= 2 (a
            GPU): vmapped chunks; a batch is padded to at least this many views, so that every
            view is solved at the same vmap width whatever its batch (symmetry_chunk_views
            likewise).
        simulation_chunk: Candidates per jitted MJX call; larger batches are split.
        simulation_threads: C MuJoCo rollout threads (0 = one per core).
        eval_batch_size: Views per batch through the evaluation's search and Poisson solve.
        metric_workers: Processes that measure the evaluation's meshes while the next batch is
            searched and meshed (0: measured in the evaluating process). The results are the
            same either way.
        progress: Show progress bars.
    """

    symmetry_chunk_views: int = 1
    symmetry_chunk_hypotheses: int = 256
    poisson_chunk_views: int = 1
    simulation_chunk: int = 512
    simulation_threads: int = 0
    eval_batch_size: int = 16
    metric_workers: int = 1
    progress: bool = True

    def __post_init__(self) -> None:
        check_fields(self)
        for name in ("symmetry_chunk_views", "symmetry_chunk_hypotheses", "poisson_chunk_views",
                     "simulation_threads", "metric_workers"):  # fmt: skip
            _int_at_least(name, getattr(self, name), 0)
        _int_at_least("simulation_chunk", self.simulation_chunk, 1)
        _int_at_least("eval_batch_size", self.eval_batch_size, 1)
        if not isinstance(self.progress, bool):
            raise ConfigError(f"progress must be true or false, got {self.progress!r}")
