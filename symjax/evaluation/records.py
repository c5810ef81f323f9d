"""Typed per-view results of the evaluation, their JSON files and the flat result table.

One :class:`ViewRecord` per view holds the found plane (:class:`PlaneResult`) and one
:class:`MeshResult` per reconstruction. Each view's record is written atomically to
``<out>/views/<dataset>__<deg>.json`` as soon as its batch is done; a file that does not parse
into a record is treated as not done.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from symjax.array_types import ArrayLike
from symjax.errors import FileFormatError
from symjax.evaluation.config import POISSON_DEPTHS

__all__ = [
    "ROW_FIELDS",
    "MeshResult",
    "PlaneResult",
    "ViewRecord",
    "jsonable",
    "load_records",
    "rows_of",
    "view_file",
]

NAN = float("nan")

#: Columns of ``results.csv``, one row per view and method. Lengths in mm, variance in mm^2,
#: centroid error as a fraction of the ground truth's oriented-box diagonal, times in seconds.
ROW_FIELDS = (
    "view",
    "dataset",
    "object",
    "orientation_deg",
    "method",
    "ok",
    "error",
    "dev_mean_mm",
    "dev_var_mm2",
    "dev_max_mm",
    "dev_p50_mm",
    "dev_p95_mm",
    "centroid_error",
    "plane_error_deg",
    "plane_error_mm",
    "completion",
    "confidence",
    "n_points",
    "n_faces",
    "build_s",
    "metric_s",
)


def _num(x: Any) -> float:
    return NAN if x is None else float(x)


@dataclasses.dataclass(frozen=True)
class MeshResult:
    """One reconstruction of one view against the ground truth.

    Attributes:
        method: ``"Del"``, ``"Mir5"`` or ``"Mir7"``.
        ok: The mesh was built and measured.
        error: Why not, else None.
        n_faces: Triangles of the mesh.
        dev_mean_mm: Mean deviation of the reference surface from the mesh, mm (MeshDev).
        dev_var_mm2: Its variance, mm^2.
        dev_max_mm: Largest deviation, mm.
        dev_p50_mm: Median deviation, mm.
        dev_p95_mm: 95th percentile, mm.
        centroid_error: Centroid error over the oriented-box diagonal of the truth (Fig. 12).
    """

    method: str
    ok: bool
    error: str | None = None
    n_faces: int = 0
    dev_mean_mm: float = NAN
    dev_var_mm2: float = NAN
    dev_max_mm: float = NAN
    dev_p50_mm: float = NAN
    dev_p95_mm: float = NAN
    centroid_error: float = NAN

    def to_json(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        del d["method"]
        return d

    @classmethod
    def from_json(cls, method: str, d: dict[str, Any]) -> MeshResult:
        return cls(
            method=method,
            ok=bool(d["ok"]),
            error=d.get("error"),
            n_faces=int(d.get("n_faces", 0)),
            **{f: _num(d.get(f)) for f in _METRIC_FIELDS},
        )


_METRIC_FIELDS = tuple(f.name for f in dataclasses.fields(MeshResult))[4:]


@dataclasses.dataclass(frozen=True)
class PlaneResult:
    """The symmetry plane found for a view and, where the truth is known, its error.

    Attributes:
        normal: (3,) unit normal, world frame.
        offset_m: Plane offset, metres (plane ``{x : normal . x = offset}``).
        vote: Its vote (Eq. 3).
        plane_error_deg: Angle to the nearest true plane, degrees (NaN: unknown).
        plane_error_mm: Offset error, mm (NaN: unknown).
        n_mirrored: Mirrored points kept.
        support: Share of the mirrored view landing on the view (the paper's case i).
        rival_support: The best support of the rival planes.
        confidence: Probability that the plane is right
            (:func:`symjax.completion.plane_confidence`).
        completion: The completion the view got: ``"mirror"``, ``"revolution"``, ``"fallback"``.
        completion_reason: Why, with the numbers that decided it.
        revolution_residual: Axis fit residual of the visible surface (NaN: no axis).
    """

    normal: tuple[float, float, float]
    offset_m: float
    vote: float
    plane_error_deg: float = NAN
    plane_error_mm: float = NAN
    n_mirrored: int = 0
    support: float = NAN
    rival_support: float = NAN
    confidence: float = NAN
    completion: str = "mirror"
    completion_reason: str = ""
    revolution_residual: float = NAN

    def to_json(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["normal"] = list(self.normal)
        return d

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> PlaneResult:
        return cls(
            normal=tuple(float(x) for x in d["normal"]),
            offset_m=float(d["offset_m"]),
            vote=_num(d.get("vote")),
            plane_error_deg=_num(d.get("plane_error_deg")),
            plane_error_mm=_num(d.get("plane_error_mm")),
            n_mirrored=int(d.get("n_mirrored", 0)),
            **{f: _num(d.get(f)) for f in ("support", "rival_support", "confidence")},
            completion=str(d.get("completion", "mirror")),
            completion_reason=str(d.get("completion_reason", "")),
            revolution_residual=_num(d.get("revolution_residual")),
        )


@dataclasses.dataclass(frozen=True)
class ViewRecord:
    """Everything the evaluation measured on one view.

    Attributes:
        view: View name ``<dataset>/<deg>``.
        dataset: Data set id.
        object: Object name.
        orientation_deg: Orientation on the table, degrees.
        source: Where the view came from (``"benchmark"``, ``"kth"``).
        has_ground_truth: A true mesh was available.
        config_key: :meth:`EvalConfig.key` of the numbers that made it.
        n_points: Observed points.
        symmetry: The found plane, or None when the search failed or did not run.
        results: One :class:`MeshResult` per method, in the configuration's order.
        timings_s: Stage name -> seconds.
    """

    view: str
    dataset: str
    object: str
    orientation_deg: float
    source: str
    has_ground_truth: bool
    config_key: str
    n_points: int
    symmetry: PlaneResult | None
    results: tuple[MeshResult, ...]
    timings_s: dict[str, float]

    @property
    def methods(self) -> tuple[str, ...]:
        return tuple(r.method for r in self.results)

    def result(self, method: str) -> MeshResult:
        """The :class:`MeshResult` of one method (``KeyError`` when it did not run)."""
        for r in self.results:
            if r.method == method:
                return r
        raise KeyError(method)

    def to_json(self) -> dict[str, Any]:
        """The record as strict JSON (NaN written as null)."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["symmetry"] = None if self.symmetry is None else self.symmetry.to_json()
        d["methods"] = {r.method: r.to_json() for r in self.results}
        del d["results"]
        return jsonable(d)

    @classmethod
    def from_json(cls, d: ArrayLike) -> ViewRecord:
        """Parses a record written by :meth:`to_json`.

        Raises:
            FileFormatError: A field is missing or has the wrong type.
        """
        try:
            return cls(
                view=str(d["view"]),
                dataset=str(d["dataset"]),
                object=str(d["object"]),
                orientation_deg=float(d["orientation_deg"]),
                source=str(d["source"]),
                has_ground_truth=bool(d["has_ground_truth"]),
                config_key=str(d["config_key"]),
                n_points=int(d["n_points"]),
                symmetry=None if d["symmetry"] is None else PlaneResult.from_json(d["symmetry"]),
                results=tuple(MeshResult.from_json(m, r) for m, r in d["methods"].items()),
                timings_s={str(k): _num(v) for k, v in d["timings_s"].items()},
            )
        except (KeyError, TypeError, ValueError, AttributeError) as e:
            raise FileFormatError(f"malformed view record: {type(e).__name__}: {e}") from None


def jsonable(obj: Any) -> Any:
    """NaN becomes null (strict JSON); read back as NaN."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    return obj


def view_file(out_dir: str | Path, name: str) -> Path:
    """Per-view result file: ``<out>/views/<dataset>__<deg>.json``."""
    return Path(out_dir) / "views" / (name.replace("/", "__") + ".json")


def load_records(
    out_dir: str | Path,
    names: Sequence[str],
    key: str,
    methods: Sequence[str],
    log: Callable[[str], None] | None = None,
) -> dict[str, ViewRecord]:
    """Per-view records already written with the configuration ``key`` and all ``methods``.

    A file that does not parse into a record is left out (recomputed, and said through
    ``log``), never trusted.
    """
    done = {}
    for name in names:
        path = view_file(out_dir, name)
        if not path.is_file():
            continue
        try:
            rec = ViewRecord.from_json(json.loads(path.read_text()))
        except (OSError, ValueError, FileFormatError) as e:
            if log is not None:
                log(f"warning: {path} is malformed ({e}); recomputing that view")
            continue
        if rec.config_key == key and all(m in rec.methods for m in methods):
            done[name] = rec
    return done


def rows_of(records: Sequence[ViewRecord], methods: Sequence[str]) -> list[dict[str, Any]]:
    """Flattens records into one row per view and method (columns :data:`ROW_FIELDS`)."""
    rows = []
    for rec in records:
        sym = rec.symmetry
        t = rec.timings_s
        for m in methods:
            r = rec.result(m)
            if m in POISSON_DEPTHS:
                build = sum(_num(t.get(k, 0.0)) for k in ("symmetry", "normals"))
                build += _num(t.get(f"poisson{POISSON_DEPTHS[m]}", 0.0))
            else:
                build = _num(t.get("delaunay", 0.0))
            rows.append(
                {
                    "view": rec.view,
                    "dataset": rec.dataset,
                    "object": rec.object,
                    "orientation_deg": rec.orientation_deg,
                    "method": m,
                    "ok": r.ok,
                    "error": r.error or "",
                    **{f: getattr(r, f) for f in _METRIC_FIELDS},
                    "plane_error_deg": NAN if sym is None else sym.plane_error_deg,
                    "plane_error_mm": NAN if sym is None else sym.plane_error_mm,
                    "completion": "" if sym is None else sym.completion,
                    "confidence": NAN if sym is None else sym.confidence,
                    "n_points": rec.n_points,
                    "n_faces": r.n_faces,
                    "build_s": build,
                    "metric_s": _num(t.get(f"metrics_{m}", 0.0)),
                }
            )
    return rows
