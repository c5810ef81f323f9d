"""Loaders and writers: depth frames, point clouds, the paper's KTH views, meshes."""

from symjax.io.depth_frame import (
    DepthFrame,
    load_camera_json,
    load_depth_frame,
    read_depth_image,
    write_camera_json,
    write_depth_png,
)
from symjax.io.kth import (
    KthCalibration,
    KthView,
    load_kth_directory,
    load_kth_view,
    read_kth_calibration,
    read_kth_segment,
    read_kth_viewpoint,
)
from symjax.io.mesh import read_mesh, write_mesh
from symjax.io.point_cloud import PointCloud, cloud_observation, read_point_cloud, write_point_cloud

__all__ = [
    "DepthFrame",
    "KthCalibration",
    "KthView",
    "PointCloud",
    "cloud_observation",
    "load_camera_json",
    "load_depth_frame",
    "load_kth_directory",
    "load_kth_view",
    "read_depth_image",
    "read_kth_calibration",
    "read_kth_segment",
    "read_kth_viewpoint",
    "read_mesh",
    "read_point_cloud",
    "write_camera_json",
    "write_depth_png",
    "write_mesh",
    "write_point_cloud",
]
