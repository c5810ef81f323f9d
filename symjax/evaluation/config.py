"""Configuration of the paper's mesh evaluation (Section V-A and V-B)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import Any

from symjax.completion.config import CompletionConfig
from symjax.datasets.stereo import StereoHead
from symjax.errors import ConfigError, unknown_name
from symjax.execution import ExecutionConfig
from symjax.surface import DelaunayConfig, NormalsConfig, PoissonConfig
from symjax.symmetry import SymmetryConfig
from symjax.validation import check_fields

__all__ = ["METHODS", "POISSON_DEPTHS", "EvalConfig", "parse_subset"]

#: The paper's three reconstructions: Delaunay baseline, mirroring + Poisson depth 5 and 7.
METHODS = ("Del", "Mir5", "Mir7")

#: Poisson octree depth of each mirroring method.
POISSON_DEPTHS = {"Mir5": 5, "Mir7": 7}


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise ConfigError(message)


@dataclasses.dataclass(frozen=True)
class EvalConfig:
    """What the evaluation runs on and how.

    Attributes:
        out_dir: Output folder (``views/`` per-view results, tables, figures, report).
        methods: Reconstructions to evaluate, a subset of :data:`METHODS`.
        subset: Subset items (see :func:`parse_subset`); empty = every view.
        data: A folder in the paper's KTH database layout, or None for the embedded benchmark.
        cache_dir: Cache of the embedded benchmark (None = ``$SYMJAX_CACHE``, else
            ``~/.cache/symjax``).
        seed: Seed of the embedded benchmark's rendering.
        n_samples: Uniform samples of the reference surface per metric (MeshDev's sampling).
        camera: The stereo head that renders the embedded benchmark.
        symmetry: Symmetry search parameters.
        completion: Mirror, revolution or fallback per view (``Mir5``/``Mir7`` mesh the chosen
            completion; ``mode="mirror"`` is the paper's).
        normals: Normal estimation parameters of the completed cloud.
        poisson: Poisson parameters of ``Mir5`` and ``Mir7`` (their ``depth`` is 5 and 7).
        delaunay: Parameters of the baseline ``Del``.
        gallery: Views shown in the gallery image (the last one is the worst Mir7 view).
        resume: Skip views whose results with the same configuration are already written.
        execution: Batch and chunk sizes, progress bar; no effect on the results.
    """

    out_dir: str = "out/eval"
    methods: tuple[str, ...] = METHODS
    subset: tuple[str, ...] = ()
    data: str | None = None
    cache_dir: str | None = None
    seed: int = 0
    n_samples: int = 5000
    camera: StereoHead = dataclasses.field(default_factory=StereoHead)
    symmetry: SymmetryConfig = dataclasses.field(default_factory=SymmetryConfig)
    completion: CompletionConfig = dataclasses.field(default_factory=CompletionConfig)
    normals: NormalsConfig = dataclasses.field(default_factory=NormalsConfig)
    poisson: PoissonConfig = dataclasses.field(default_factory=PoissonConfig)
    delaunay: DelaunayConfig = dataclasses.field(default_factory=DelaunayConfig)
    gallery: int = 4
    resume: bool = True
    execution: ExecutionConfig = dataclasses.field(default_factory=ExecutionConfig)

    def __post_init__(self) -> None:
        check_fields(self)
        _require(len(self.methods) > 0, "methods is empty; expected some of Del, Mir5, Mir7")
        for m in self.methods:
            if m not in METHODS:
                raise unknown_name("method", m, METHODS)
        _require(len(set(self.methods)) == len(self.methods), f"methods repeat: {self.methods}")
        _require(
            isinstance(self.n_samples, int) and self.n_samples >= 100,
            f"n_samples must be an int >= 100, got {self.n_samples!r}",
        )
        _require(
            isinstance(self.gallery, int) and self.gallery >= 0,
            f"gallery must be an int >= 0, got {self.gallery!r}",
        )
        parse_subset(self.subset)

    def key(self) -> str:
        """Hash of everything that changes a view's numbers (not the output or execution).

        A per-view result is reused on resume only when its key matches, so that a run with
        another symmetry configuration never mixes with older results.
        """
        keep = {
            "symmetry": dataclasses.asdict(self.symmetry),
            "completion": dataclasses.asdict(self.completion),
            "normals": dataclasses.asdict(self.normals),
            "poisson": {k: v for k, v in dataclasses.asdict(self.poisson).items() if k != "depth"},
            "delaunay": dataclasses.asdict(self.delaunay),
            "n_samples": self.n_samples,
            "seed": self.seed,
            "camera": dataclasses.asdict(self.camera),
            "data": self.data,
            # 3: completions cut at the table; 4: exact surface centroids; 5: completion choice
            "version": 5,
        }
        text = json.dumps(keep, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    def to_json(self) -> dict[str, Any]:
        """The configuration as plain JSON."""
        return json.loads(json.dumps(dataclasses.asdict(self), default=str))


def parse_subset(items: tuple[str, ...] | list[str]) -> dict[str, Any]:
    """Parses subset items into filters.

    Items (combined: data set / view filters or-ed, orientation filters or-ed, then the two
    and-ed, then the count applied last):

    * ``N`` (an integer): keep the first N views;
    * ``<deg>deg`` (e.g. ``90deg``): keep that orientation;
    * anything else: a data set id (``025_mug``) or a view name (``025_mug/045``).

    Args:
        items: Subset items.

    Returns:
        ``{"names": [...], "orientations": [...], "first": int | None}``.

    Raises:
        ConfigError: On an empty item, a count < 1, a bad orientation or two counts.
    """
    names: list[str] = []
    degs: list[float] = []
    first: int | None = None
    # "a,b" and ("a", "b") alike: the command line may pass either.
    split = [part for raw in items for part in (str(raw).split(",") if "," in str(raw) else [raw])]
    for raw in split:
        item = str(raw).strip()
        _require(bool(item), "empty subset item; expected N, <deg>deg, a data set id or view name")
        if item.isdigit():
            _require(first is None, f"two view counts in the subset: {first} and {item}")
            first = int(item)
            _require(first >= 1, f"the view count must be >= 1, got {item}")
        elif item.lower().endswith("deg"):
            try:
                degs.append(float(item[:-3]))
            except ValueError:
                raise ConfigError(f"bad orientation {item!r}; expected e.g. 45deg") from None
        else:
            names.append(item)
    return {"names": names, "orientations": degs, "first": first}
