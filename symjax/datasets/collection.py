"""The embedded 128-view benchmark: 16 data sets x 8 orientations seen by a simulated stereo head.

:func:`benchmark` returns the views of the paper's protocol (Section V-A.1) for the 12 scanned
objects of :mod:`symjax.datasets.catalogue`: each data set is seen in 8 orientations 0, 45, ...,
315 deg about the table normal (0 deg = the object's longest table-projected dimension parallel to
the image plane), rendered by :mod:`symjax.datasets.render`.

Views are generated once into a cache folder (``$SYMJAX_CACHE/benchmark-v<version>``, else
``~/.cache/symjax/benchmark-v<version>``, or the ``cache_dir`` argument): one compressed ``.npz``
per view plus an ``index.json`` per seed and configuration, all written atomically, by a process
pool. Later runs load them; a change of :data:`GENERATOR_VERSION` (or of the configuration)
regenerates.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import multiprocessing
import os
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

from symjax import _interrupt, resources
from symjax._atomic import atomic_write_bytes, atomic_write_json
from symjax.datasets.catalogue import DATASET_IDS, OBJECTS_VERSION
from symjax.datasets.objects import ObjectModel, load_dataset_object
from symjax.datasets.render import GENERATOR_VERSION, ORIENTATIONS_DEG, BenchmarkConfig, render_view
from symjax.datasets.view import View
from symjax.datasets.view_file import decode_view, encode_view, view_file_name
from symjax.errors import InvalidInputError, unknown_name

__all__ = ["Benchmark", "benchmark", "default_cache_dir", "view_names"]


def default_cache_dir() -> Path:
    """``$SYMJAX_CACHE/benchmark-v<version>``, else ``~/.cache/symjax/benchmark-v<version>``."""
    return resources.cache_dir(f"benchmark-v{GENERATOR_VERSION}")


def view_names(datasets: Iterable[str] = DATASET_IDS, orientations=ORIENTATIONS_DEG) -> list[str]:
    """View names ``"<dataset>/<deg:03d>"`` in data set then orientation order."""
    return [f"{d}/{int(round(o)):03d}" for d in datasets for o in orientations]


# ----------------------------------------------------------------------------------------------
# Rendering
# ----------------------------------------------------------------------------------------------


def _generate_dataset(
    dataset: str,
    orientations: list[float],
    seed: int,
    config: BenchmarkConfig,
    root: str,
    folder: str,
) -> list[tuple[str, int]]:
    """Worker: preprocesses one data set's object (cached) and writes its views."""
    obj = load_dataset_object(dataset, cache_dir=root)
    out = []
    for o in orientations:
        _interrupt.check()  # a Ctrl-C that JAX's GC hook swallowed still stops here
        view = render_view(obj, o, seed, config)
        atomic_write_bytes(Path(folder) / view_file_name(view.name), encode_view(view))
        out.append((view.name, len(view.points)))
    return out


# ----------------------------------------------------------------------------------------------
# The benchmark
# ----------------------------------------------------------------------------------------------


class Benchmark(Sequence[View]):
    """The generated views, loaded lazily from the cache (a sequence of :class:`View`).

    Index by position or by view name (``bench["025_mug/045"]``).

    Attributes:
        names: View names, in data set then orientation order.
        folder: Folder holding the views and ``index.json``.
        root: Cache root (holds the preprocessed objects too).
    """

    def __init__(self, names: list[str], folder: Path, root: Path):
        self.names = list(names)
        self.folder = Path(folder)
        self.root = Path(root)
        self._objects: dict[str, ObjectModel] = {}

    def __len__(self) -> int:
        return len(self.names)

    def __getitem__(self, key):  # type: ignore[override]
        if isinstance(key, slice):
            return [self[i] for i in range(*key.indices(len(self)))]
        if isinstance(key, str):
            if key not in self.names:
                raise unknown_name("benchmark view", key, self.names)
            name = key
        else:
            name = self.names[key]
        dataset = name.split("/")[0]
        if dataset not in self._objects:
            self._objects[dataset] = load_dataset_object(dataset, cache_dir=self.root)
        return decode_view(self.folder / view_file_name(name), self._objects[dataset])

    def __iter__(self) -> Iterator[View]:
        for i in range(len(self)):
            yield self[i]

    def n_points(self, i: int) -> int:
        """Observed points of view ``i``, from the index (the view is not loaded)."""
        if not hasattr(self, "_index"):
            self._index = json.loads((self.folder / "index.json").read_text())["views"]
        return int(self._index[self.names[i]]["n_points"])

    @property
    def datasets(self) -> list[str]:
        """Data set ids present, in order."""
        return list(dict.fromkeys(n.split("/")[0] for n in self.names))


def _resolve_subset(subset: Any, orientations) -> list[str]:
    all_names = view_names(DATASET_IDS, orientations)
    if subset is None:
        return all_names
    items = [subset] if isinstance(subset, str) else list(subset)
    if not items:
        raise InvalidInputError("subset is empty; pass None for all 128 views")
    chosen: list[str] = []
    for it in items:
        if not isinstance(it, str):
            raise InvalidInputError(f"subset items must be strings, got {type(it).__name__}")
        if it in DATASET_IDS:
            chosen += [n for n in all_names if n.split("/")[0] == it]
        elif it in all_names:
            chosen.append(it)
        else:
            raise unknown_name("benchmark data set or view", it, list(DATASET_IDS))
    order = {n: i for i, n in enumerate(all_names)}
    return sorted(dict.fromkeys(chosen), key=order.__getitem__)


def benchmark(
    subset: Any = None,
    cache_dir: str | os.PathLike | None = None,
    seed: int = 0,
    config: BenchmarkConfig = BenchmarkConfig(),
    workers: int | None = None,
    regenerate: bool = False,
) -> Benchmark:
    """The benchmark views, generated into the cache on first use.

    Args:
        subset: None (all 16 x 8 = 128 views), a data set id (``"025_mug"``,
            ``"003_cracker_box_lying"``), a view name (``"025_mug/045"``) or a list of them.
        cache_dir: Cache root; default ``$SYMJAX_CACHE/benchmark-v<version>`` or
            ``~/.cache/symjax/benchmark-v<version>``.
        seed: Base seed of camera placement, object placement and noise.
        config: Rendering configuration.
        workers: Processes for generation (default: the CPU count, at most 8; 1 = in process).
        regenerate: Render again even if cached.

    Returns:
        A :class:`Benchmark` sequence of :class:`View` (loaded lazily).

    Raises:
        UnknownNameError: If a subset item is not a data set id or view name.
    """
    names = _resolve_subset(subset, config.orientations_deg)
    root = Path(cache_dir).expanduser() if cache_dir is not None else default_cache_dir()
    folder = root / f"seed{int(seed)}-{config.key()}"
    index_path = folder / "index.json"
    index = _read_index(index_path, seed, config)
    missing = [
        n
        for n in names
        if regenerate or n not in index["views"] or not (folder / view_file_name(n)).is_file()
    ]
    if missing:
        by_ds: dict[str, list[float]] = {}
        for n in missing:
            ds, deg = n.split("/")
            by_ds.setdefault(ds, []).append(float(deg))
        jobs = [(ds, degs, int(seed), config, str(root), str(folder)) for ds, degs in by_ds.items()]
        n_workers = min(len(jobs), workers or min(8, os.cpu_count() or 1))
        results: list[tuple[str, int]] = []
        if n_workers <= 1:
            for job in jobs:
                results += _generate_dataset(*job)
        else:
            # spawn: forking a process that has initialised JAX's thread pools can deadlock.
            ctx = multiprocessing.get_context("spawn")
            # Largest jobs first balances the workers.
            jobs.sort(key=lambda j: -len(j[1]))
            pool = cf.ProcessPoolExecutor(n_workers, mp_context=ctx)
            try:
                for res in pool.map(_generate_dataset_star, jobs):
                    _interrupt.check()
                    results += res
            except BaseException:
                # Ctrl-C or a failed job: stop now rather than wait for every queued dataset.
                pool.shutdown(wait=False, cancel_futures=True)
                raise
            pool.shutdown()
        # Re-read: another process may have added views meanwhile.
        index = _read_index(index_path, seed, config)
        for name, n_points in results:
            index["views"][name] = {"file": view_file_name(name), "n_points": n_points}
        atomic_write_json(index_path, index)
    return Benchmark(names, folder, root)


def _generate_dataset_star(job):
    return _generate_dataset(*job)


def _read_index(path: Path, seed: int, config: BenchmarkConfig) -> dict[str, Any]:
    fresh = {
        "generator_version": GENERATOR_VERSION,
        "objects_version": OBJECTS_VERSION,
        "seed": int(seed),
        "config_key": config.key(),
        "views": {},
    }
    if not path.is_file():
        return fresh
    try:
        index = json.loads(path.read_text())
    except (OSError, ValueError):
        return fresh  # a corrupt index only costs a regeneration
    same = all(index.get(k) == fresh[k] for k in fresh if k != "views")
    if not same or not isinstance(index.get("views"), dict):
        return fresh
    return index
