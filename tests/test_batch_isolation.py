"""One bad view never spoils a batch: over random batch compositions of good and bad views,
each good view's result equals its result alone (a batch of one), bit for bit on the CPU, and
each bad view gets its own failure record while the others complete."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from symjax import configs
from symjax.datasets.primitives import K_DEFAULT, primitive_view
from symjax.errors import SymjaxError
from symjax.surface import PoissonConfig, poisson_reconstruct_batch
from symjax.symmetry import search_batch

PAPER = configs.load("paper").symmetry  # 35 hypotheses keep every batch quick
K_SMALL = K_DEFAULT * np.array([[0.5], [0.5], [1.0]])


def _view(kind: str, yaw: float, seed: int):
    obs, _ = primitive_view(kind, yaw, noise=0.001, seed=seed, K=K_SMALL, width=320, height=240)
    return obs


GOOD = [_view("box", math.radians(30), 0), _view("cylinder", 1.0, 1), _view("bottle", 0.2, 2)]
NAN = dataclasses.replace(GOOD[0], points=np.asarray(GOOD[0].points).copy())
NAN.points[7] = np.nan
ONE_POINT = dataclasses.replace(
    GOOD[1], points=np.repeat(np.asarray(GOOD[1].points)[:1], len(GOOD[1].points), axis=0)
)
BAD = [NAN, ONE_POINT]
POOL = GOOD + BAD  # indices 0-2 good, 3-4 bad

ALONE = [search_batch([v], PAPER)[0] for v in GOOD]


def _same(a, b) -> bool:
    for f in dataclasses.fields(a):
        if f.name == "errors":
            continue
        x, y = np.asarray(getattr(a, f.name)), np.asarray(getattr(b, f.name))
        if x.shape != y.shape:  # point arrays padded to the batch's largest view
            n = min(len(x), len(y))
            extra = x[n:] if len(x) > n else y[n:]
            if f.name in ("valid", "mirrored_keep") and extra.any():
                return False  # padding rows must never count as points
            x, y = x[:n], y[:n]
        if not np.array_equal(x, y, equal_nan=True):
            return False
    return True


@settings(max_examples=12, deadline=None)
@given(
    st.lists(st.integers(0, len(POOL) - 1), min_size=1, max_size=5).filter(
        lambda c: any(i < len(GOOD) for i in c)
    )
)
def test_search_batch_views_are_independent(composition):
    res = search_batch([POOL[i] for i in composition], PAPER)
    assert res.ok.tolist() == [i < len(GOOD) for i in composition]
    for k, i in enumerate(composition):
        if i < len(GOOD):
            assert _same(res[k], ALONE[i]), (composition, k)
        else:
            assert isinstance(res.errors[k], SymjaxError)
            assert np.all(np.isnan(np.asarray(res.normal[k])))  # never a usable zero plane
            with pytest.raises(SymjaxError):
                res[k]


def _cloud(n: int, r: float, c: float, seed: int):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return (r * d + c, d, None)


P_GOOD = [_cloud(1500, 0.04, 0.0, 0), _cloud(2600, 0.05, 0.3, 1), _cloud(900, 0.03, -0.2, 2)]
STRAY = _cloud(600, 0.04, 0.0, 3)
STRAY[0][0] = [9.0, 0.0, 0.0]
P_BAD = [
    (P_GOOD[0][0][:5], P_GOOD[0][1][:5], None),
    (P_GOOD[1][0], P_GOOD[1][1] * np.nan, None),
    STRAY,
]
P_POOL = P_GOOD + P_BAD
PCFG = PoissonConfig(depth=5)
P_ALONE = [poisson_reconstruct_batch([v], PCFG)[0] for v in P_GOOD]


@settings(max_examples=15, deadline=None)
@given(st.lists(st.integers(0, len(P_POOL) - 1), min_size=1, max_size=6))
def test_poisson_batch_views_are_independent(composition):
    out = poisson_reconstruct_batch([P_POOL[i] for i in composition], PCFG, errors="keep")
    for k, i in enumerate(composition):
        if i < len(P_GOOD):
            assert np.array_equal(out[k].vertices, P_ALONE[i].vertices), (composition, k)
            assert np.array_equal(out[k].faces, P_ALONE[i].faces)
        else:
            assert isinstance(out[k], SymjaxError), (composition, k, out[k])


def test_search_or_errors_names_each_failed_view_and_keeps_the_others():
    from symjax.symmetry import search_or_errors

    res, errors = search_or_errors([GOOD[0], BAD[1], GOOD[2]], PAPER)
    assert errors[0] is None and errors[2] is None and isinstance(errors[1], SymjaxError)
    assert _same(res[0], ALONE[0]) and _same(res[2], ALONE[2])
    given, again = search_or_errors([GOOD[0]], PAPER, search=res)  # the caller's search
    assert given is res and again == [None]
    none, all_bad = search_or_errors([GOOD[0]], {"not": "a config"})  # the batch fails
    assert none is None and isinstance(all_bad[0], SymjaxError)
