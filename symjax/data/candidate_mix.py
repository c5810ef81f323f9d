"""A shard's candidates: shares of the paper's three generators and the dense sampler's fill."""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np

from symjax.data.dense_sampler import dense_candidates
from symjax.data.spec import GENERATORS, DatasetSpec
from symjax.errors import SymjaxError

__all__ = ["mixed_candidates", "shard_rng_seed"]


def shard_rng_seed(seed: int, *names: str) -> list[int]:
    """A seed sequence for one shard: stable across processes (crc32, not the salted hash)."""
    return [int(seed), *(zlib.crc32(n.encode()) for n in names)]


def mixed_candidates(
    mesh: Any, hand: Any, spec: DatasetSpec, candidate_config: Any, table: Any, seed: list[int]
):
    """``spec.n_candidates`` candidates for one object and hand.

    Each of the paper's generators in ``spec.shares`` contributes a random subset of its output
    of at most its share; the dense sampler fills the rest.

    Returns:
        ``(Candidates, generator (N,) int8 index into GENERATORS, counts {generator: n})``.
    """
    from symjax.grasp import Candidates, generate

    rng = np.random.default_rng(seed)
    n = spec.n_candidates
    parts, codes, counts = [], [], {}
    for name, share in spec.shares:
        want = int(round(share * n))
        if want == 0:
            continue
        try:
            cs = generate(mesh, name, config=candidate_config, table=table, hand=hand,
                          seed=int(rng.integers(2**31)))  # fmt: skip
        except SymjaxError:
            cs = None  # e.g. kth finds no grasp points: the dense sampler fills in
        if cs is None or len(cs) == 0:
            counts[name] = 0
            continue
        k = min(want, len(cs))
        pick = np.sort(rng.choice(len(cs), size=k, replace=False))
        parts.append(cs.candidates.take(pick))
        codes.append(np.full(k, GENERATORS.index(name), np.int8))
        counts[name] = k
    rest = n - sum(counts.values())
    dense, _ = dense_candidates(
        mesh, rest, config=spec.dense, table=table, hand=hand, seed=int(rng.integers(2**31)),
        candidate_config=candidate_config,
    )  # fmt: skip
    parts.append(dense)
    codes.append(np.full(len(dense), GENERATORS.index("dense"), np.int8))
    counts["dense"] = len(dense)
    return Candidates.concatenate(parts), np.concatenate(codes), counts
