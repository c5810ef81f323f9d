"""Named presets: one TOML file fills every stage's frozen config (see ``configs/`` at the top of
the checkout, packaged as ``symjax/presets``).

A preset file has one table per concept (``[symmetry]``, ``[completion]``, ``[normals]``,
``[poisson]``, ``[delaunay]``, ``[segmentation]``, ``[decompose]``, ``[candidates]``,
``[simulation]``, ``[robustness]``, ``[motion]``, ``[platform]``, ``[camera]``, ``[execution]``,
``[generate]``, ``[evaluation]``), each holding only the fields it changes from the defaults next
to the code. ``extends = "name"`` starts from another preset. Job configs that need several concepts
(:class:`~symjax.evaluation.EvalConfig`) are composed from the tables, so each value lives in one
place.
"""

from __future__ import annotations

import copy
import dataclasses
import tomllib
from pathlib import Path
from typing import Any

from symjax.completion.config import CompletionConfig
from symjax.data.spec import DatasetSpec
from symjax.datasets.stereo import StereoHead
from symjax.decompose.config import DecomposeConfig
from symjax.errors import ConfigError, FileFormatError, MissingFileError, unknown_name
from symjax.evaluation.config import EvalConfig
from symjax.execution import ExecutionConfig
from symjax.grasp.config import CandidateConfig
from symjax.grasp.robustness import RobustnessConfig
from symjax.grasp.sim_config import SimulationConfig
from symjax.motion.config import MotionConfig
from symjax.perception.config import SegmentationConfig
from symjax.resources import preset_dir
from symjax.robots.platform import PlatformConfig
from symjax.surface.config import DelaunayConfig, NormalsConfig, PoissonConfig
from symjax.symmetry.config import SymmetryConfig
from symjax.validation import build

__all__ = ["SECTIONS", "Preset", "load", "preset_names"]

#: Table name -> the config dataclass it fills.
SECTIONS: dict[str, type] = {
    "platform": PlatformConfig,
    "camera": StereoHead,
    "segmentation": SegmentationConfig,
    "symmetry": SymmetryConfig,
    "completion": CompletionConfig,
    "normals": NormalsConfig,
    "poisson": PoissonConfig,
    "delaunay": DelaunayConfig,
    "decompose": DecomposeConfig,
    "candidates": CandidateConfig,
    "simulation": SimulationConfig,
    "robustness": RobustnessConfig,
    "motion": MotionConfig,
    "execution": ExecutionConfig,
    "generate": DatasetSpec,
}

# EvalConfig fields that come from the other tables, not from [evaluation].
_COMPOSED = {"symmetry", "completion", "normals", "poisson", "delaunay", "execution", "camera"}


@dataclasses.dataclass(frozen=True)
class Preset:
    """Every stage's configuration, as one named preset sets it.

    Attributes:
        name: Preset name, or the path of a user's file.
        description: What the preset is for.
        platform: Robot, hand and grasp generator.
        camera: The head's stereo camera (intrinsics, distance and elevation ranges).
        segmentation: Table plane and object segmentation.
        symmetry: Symmetry search (paper Section II-A).
        completion: Mirror, revolution or fallback per view, and the plane's confidence.
        normals: Normal estimation.
        poisson: Poisson reconstruction.
        delaunay: The paper's Delaunay baseline.
        decompose: coacd convex decomposition.
        candidates: Grasp candidate generators.
        simulation: Grasp rollouts.
        robustness: Perturbed hand poses in the grasp ranking.
        motion: Arm motion planning (IK, approach, transit, timing).
        execution: Batch and chunk sizes (speed only).
        generate: A grasp data set's objects, hands and counts (``symjax generate``).
        evaluation: The 128-view evaluation, composed from the tables above.
    """

    name: str
    description: str
    platform: PlatformConfig
    camera: StereoHead
    segmentation: SegmentationConfig
    symmetry: SymmetryConfig
    completion: CompletionConfig
    normals: NormalsConfig
    poisson: PoissonConfig
    delaunay: DelaunayConfig
    decompose: DecomposeConfig
    candidates: CandidateConfig
    simulation: SimulationConfig
    robustness: RobustnessConfig
    motion: MotionConfig
    execution: ExecutionConfig
    generate: DatasetSpec
    evaluation: EvalConfig


def preset_names() -> tuple[str, ...]:
    """Names of the packaged presets (the TOML files of ``configs/``)."""
    return tuple(sorted(p.stem for p in preset_dir().glob("*.toml")))


def _read(name_or_path: str | Path) -> tuple[dict[str, Any], str]:
    text = str(name_or_path)
    is_path = text.endswith(".toml") or "/" in text or "\\" in text
    path = Path(text).expanduser() if is_path else preset_dir() / f"{text}.toml"
    if not is_path and not path.is_file():
        raise unknown_name("preset", text, preset_names())
    if not path.is_file():
        raise MissingFileError(f"preset file {str(path)!r} does not exist; expected a .toml file")
    try:
        return tomllib.loads(path.read_text()), path.name
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise FileFormatError(f"{path}: not valid TOML: {e}") from None


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _nested(overrides: dict[str, Any]) -> dict[str, Any]:
    """``{"symmetry.n_angles": 9}`` and ``{"symmetry": {"n_angles": 9}}`` alike, nested."""
    out: dict[str, Any] = {}
    for key, value in overrides.items():
        parts = str(key).split(".")
        if len(parts) == 1:
            out = _merge(out, {key: value})
            continue
        node: dict[str, Any] = {}
        cur = node
        for p in parts[:-1]:
            cur[p] = {}
            cur = cur[p]
        cur[parts[-1]] = value
        out = _merge(out, node)
    return out


def _raw(name_or_path: str | Path, seen: tuple[str, ...] = ()) -> tuple[dict[str, Any], str]:
    table, source = _read(name_or_path)
    parent = table.pop("extends", None)
    if parent is None:
        return table, source
    if not isinstance(parent, str):
        raise ConfigError(f"{source}: extends = {parent!r}; expected a preset name")
    if parent in seen:
        raise ConfigError(f"{source}: extends {parent!r} again (a cycle: {' -> '.join(seen)})")
    base, _ = _raw(parent, (*seen, str(name_or_path)))
    return _merge(base, table), source


def load(name_or_path: str | Path = "default", overrides: dict[str, Any] | None = None) -> Preset:
    """Loads a named preset or a user's TOML file into typed configs.

    Args:
        name_or_path: A preset name (:func:`preset_names`: ``paper``, ``default``, ``kth``,
            ``uji``, ``ci``) or the path of a ``.toml`` file in the same layout.
        overrides: Values set on top, as ``{"symmetry.n_angles": 9}`` or
            ``{"symmetry": {"n_angles": 9}}``.

    Returns:
        The :class:`Preset`.

    Raises:
        UnknownNameError: No preset of that name.
        MissingFileError: The file does not exist.
        FileFormatError: The file is not valid TOML.
        ConfigError: An unknown table or key, a wrong type or an out-of-range value; the message
            names the file, the key, the value and what is accepted.
    """
    table, source = _raw(name_or_path)
    if overrides:
        table = _merge(table, _nested(overrides))
        source = f"{source} (with overrides)"
    description = table.pop("description", "")
    if not isinstance(description, str):
        raise ConfigError(f"{source}: description = {description!r}; expected a string")
    evaluation = table.pop("evaluation", {})
    known = (*SECTIONS, "evaluation", "description", "extends")
    sections: dict[str, Any] = {}
    for key, value in table.items():
        if key not in SECTIONS:
            raise ConfigError(
                f"{source}: unknown table or key {key!r}; expected one of: {', '.join(known)}"
            )
        if not isinstance(value, dict):
            raise ConfigError(f"{source}: {key} = {value!r}; expected a table [{key}]")
    for key, cls in SECTIONS.items():
        sections[key] = build(cls, table.get(key, {}), f"{source} [{key}]")
    if not isinstance(evaluation, dict):
        raise ConfigError(f"{source}: evaluation = {evaluation!r}; expected a table [evaluation]")
    for key in evaluation:
        if key in _COMPOSED:
            raise ConfigError(
                f"{source} [evaluation]: {key!r} comes from the [{key}] table; set it there"
            )
    composed = {k: sections[k] for k in _COMPOSED}
    eval_cfg = build(EvalConfig, evaluation, f"{source} [evaluation]", EvalConfig(**composed))
    return Preset(name=str(name_or_path), description=description, evaluation=eval_cfg, **sections)
