"""Table-top perception: the table plane and one observation per object on it."""

from symjax.perception.clusters import cloud_clusters, image_clusters, statistical_outliers
from symjax.perception.config import SegmentationConfig
from symjax.perception.ransac import fit_table_plane
from symjax.perception.segmentation import ObjectInfo, TableScene, segment

__all__ = [
    "ObjectInfo",
    "SegmentationConfig",
    "TableScene",
    "cloud_clusters",
    "fit_table_plane",
    "image_clusters",
    "segment",
    "statistical_outliers",
]
