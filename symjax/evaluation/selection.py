"""Which views the evaluation runs on: the embedded benchmark or a KTH-layout folder, with the
subset filters of :func:`symjax.evaluation.parse_subset` applied."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from symjax.errors import InvalidInputError, MissingFileError
from symjax.evaluation.config import EvalConfig, parse_subset

__all__ = ["select_views"]

NAN = float("nan")


class _KthViews(Sequence):
    """The views of a KTH-layout folder as a sequence with names (loaded up front)."""

    def __init__(self, views: list):
        self._views = views
        self.names = [v.name for v in views]

    def __len__(self) -> int:
        return len(self._views)

    def __getitem__(self, i):
        return self._views[i]


def _filter_names(names: list[str], subset: tuple[str, ...], datasets: set[str]) -> list[int]:
    """Indices of ``names`` kept by the subset items (see :func:`parse_subset`)."""
    spec = parse_subset(subset)
    keep = list(range(len(names)))
    if spec["names"]:
        wanted = set(spec["names"])
        unknown = sorted(wanted - datasets - set(names))
        if unknown:
            raise InvalidInputError(
                f"unknown data set or view {unknown[0]!r} in --subset; known data sets: "
                + ", ".join(sorted(datasets))
            )
        keep = [i for i in keep if names[i] in wanted or names[i].split("/")[0] in wanted]
    if spec["orientations"]:
        degs = spec["orientations"]

        def deg_of(n: str) -> float:
            tail = n.rsplit("/", 1)[-1]
            return float(tail) if tail.isdigit() else NAN

        keep = [i for i in keep if any(abs(deg_of(names[i]) - d) < 1e-6 for d in degs)]
    if spec["first"] is not None:
        keep = keep[: spec["first"]]
    if not keep:
        raise InvalidInputError(f"--subset {','.join(subset)} selects no view")
    return keep


def select_views(config: EvalConfig) -> Sequence:
    """The views to evaluate: the embedded benchmark or a KTH-layout folder, subset applied.

    Returns:
        A sequence of :class:`~symjax.datasets.View` with a ``names`` attribute (benchmark
        views are loaded lazily, generated into the cache on first use).

    Raises:
        MissingFileError: ``config.data`` is not a folder or holds no view.
        FileFormatError: A file of ``config.data`` is corrupt.
        InvalidInputError: The subset names an unknown data set or selects nothing.
    """
    if config.data is not None:
        from symjax.datasets import View
        from symjax.io import load_kth_directory

        root = Path(config.data).expanduser()
        if root.is_file():
            raise InvalidInputError(
                f"--data {str(root)!r} is a file; expected a folder in the KTH database layout"
            )
        if not root.is_dir():
            raise MissingFileError(f"--data folder {str(root)!r} does not exist")
        views = [View.from_kth(k) for k in load_kth_directory(root)]
        names = [v.name for v in views]
        if len(set(names)) != len(names):
            raise InvalidInputError(f"--data folder {str(root)!r} holds views with equal names")
        keep = _filter_names(names, config.subset, {v.dataset for v in views})
        return _KthViews([views[i] for i in keep])

    from symjax.datasets import DATASET_IDS, BenchmarkConfig, benchmark, view_names

    names = view_names()
    keep = _filter_names(names, config.subset, set(DATASET_IDS))
    return benchmark(
        [names[i] for i in keep],
        cache_dir=config.cache_dir,
        seed=config.seed,
        config=BenchmarkConfig(head=config.camera),
    )
