"""Which shape completes a view, and how sure it is (beyond the paper).

Modules: ``config`` (:class:`CompletionConfig`), ``support`` (the plane's support, the paper's
case i), ``confidence`` (the plane's calibrated confidence), ``revolution`` (axis fit and
completion by revolving), ``fallback`` (what replaces a mirror that is likely wrong), ``choice``
(:func:`choose_completion`: the shape a view gets, and why), ``shapes``
(:func:`plausible_shapes`: the K most plausible shapes, weighted, for planning under
uncertainty).
"""

from symjax.completion.choice import Completion, choose_completion
from symjax.completion.confidence import (
    CONFIDENCE_MODEL,
    confidence_features,
    plane_confidence,
    roc_auc,
)
from symjax.completion.config import CompletionConfig
from symjax.completion.fallback import footprint_hull, grid_planes, supported_plane
from symjax.completion.revolution import RevolutionFit, fit_revolution, revolve
from symjax.completion.shapes import ShapeSet, distinct_plane, plausible_shapes, shape_weight
from symjax.completion.support import SupportIndex, plane_support

__all__ = [
    "CONFIDENCE_MODEL",
    "Completion",
    "CompletionConfig",
    "RevolutionFit",
    "ShapeSet",
    "SupportIndex",
    "choose_completion",
    "confidence_features",
    "distinct_plane",
    "fit_revolution",
    "footprint_hull",
    "grid_planes",
    "plane_confidence",
    "plane_support",
    "plausible_shapes",
    "revolve",
    "roc_auc",
    "shape_weight",
    "supported_plane",
]
