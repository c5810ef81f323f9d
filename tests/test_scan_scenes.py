"""Seeded table scenes: resting, not intersecting, seen by the head camera, reproducible."""

from __future__ import annotations

import numpy as np
import pytest

from symjax.datasets.scan_scenes import head_camera, scan_scene
from symjax.grasp import inside_mesh


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return scan_scene("uji", 4, seed=3, cache_dir=tmp_path_factory.mktemp("objects"))


def test_objects_rest_on_the_table_without_intersecting(scene):
    assert len(scene.meshes) == len(scene.names) == 4
    for m in scene.meshes:
        assert abs(m.vertices[:, 2].min() - scene.table_height) < 0.003  # resting on it
    for i, a in enumerate(scene.meshes):
        for b in scene.meshes[i + 1 :]:
            assert not inside_mesh(np.asarray(a.vertices)[::7], b).any()
    # Upright and inside the arm's workspace.
    assert np.all(scene.poses[:, 2, 2] > 0.95)
    assert np.all((scene.poses[:, 0, 3] > 0.45) & (scene.poses[:, 0, 3] < 0.85))


def test_labels_match_the_projected_meshes(scene):
    cam = scene.camera
    for i, m in enumerate(scene.meshes):
        mask = scene.mask(i)
        assert mask.sum() > 500
        uv, z = (np.asarray(x) for x in cam.project(m.vertices))
        c = np.round(uv.mean(0)).astype(int)
        ys, xs = np.nonzero(mask)
        assert abs(xs.mean() - c[0]) < 40 and abs(ys.mean() - c[1]) < 40
    noisy = scene.depth[scene.labels > 0]
    assert (noisy > 0).mean() > 0.9  # the stereo model leaves most object pixels with depth


def test_head_camera_sees_the_workspace():
    for robot in ("kth", "uji"):
        cam = head_camera(robot)
        uv, z = (np.asarray(x) for x in cam.project(np.array([[0.65, 0.0, 0.75]])))
        assert z[0] > 0.5 and 0 < uv[0, 0] < cam.width and 0 < uv[0, 1] < cam.height


def test_same_seed_same_scene(scene, tmp_path):
    again = scan_scene("uji", 4, seed=3, cache_dir=tmp_path)
    assert again.names == scene.names
    np.testing.assert_allclose(again.poses, scene.poses, atol=1e-9)
    np.testing.assert_array_equal(again.depth, scene.depth)
    other = scan_scene("uji", 4, seed=4, cache_dir=tmp_path)
    assert not np.allclose(other.poses[:, :3, 3], scene.poses[:, :3, 3])
