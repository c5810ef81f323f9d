"""Grasp training data (``symjax generate``): ACRONYM's keys read the way its loader reads them,
typed loading, the manifest, resume after deletion, truncation and interruption, bit-identical
reruns, the dense sampler, and Ray with a worker killed mid-run."""

from __future__ import annotations

import json
import os
import shutil
import signal
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from symjax import configs, grasp, hands
from symjax.cli import main as cli_main
from symjax.data import (
    KEYS,
    DatasetSpec,
    DenseSamplerConfig,
    GenerateConfig,
    dense_candidates,
    generate_dataset,
    load_grasps,
)
from symjax.data.acronym_file import REQUIRED
from symjax.errors import OutputError
from symjax.table import TablePlane

CI = configs.load("ci")


@pytest.fixture(scope="session")
def ci_data(tmp_path_factory) -> Path:
    """``symjax generate --config ci``: 3 objects x 2 hands, one view each, run once."""
    out = tmp_path_factory.mktemp("generate") / "ci"
    assert cli_main(["generate", "--config", "ci", "--out-dir", str(out)]) == 0
    return out


def _files(out: Path) -> list[Path]:
    return sorted((out / "grasps").glob("*/*.h5"))


def test_generate_ci_writes_every_shard(ci_data):
    spec = CI.generate
    files = _files(ci_data)
    assert len(files) == len(spec.objects) * len(spec.hands) == 4
    doc = json.loads((ci_data / "manifest.json").read_text())
    assert doc["complete"] and doc["n_shards"] == 4
    assert sorted(r["file"] for r in doc["shards"]) == sorted(
        str(f.relative_to(ci_data)) for f in files
    )
    for r in doc["shards"]:
        assert r["n_grasps"] == spec.n_candidates
        assert {"object", "hand", "seed", "config_hash", "symjax_version", "wall_s"} <= set(r)
        assert 0.0 < r["success_rate"] < 1.0, r  # labels that mean something: some hold, some not


def test_files_read_like_acronyms_loader(ci_data):
    """acronym_tools.load_grasps and load_mesh, key by key: transforms, object_in_gripper, the
    mesh file relative to the data set and its scale."""
    for path in _files(ci_data):
        data = h5py.File(path, "r")
        T = np.array(data["grasps/transforms"])
        success = np.array(data["grasps/qualities/flex/object_in_gripper"])
        mesh_fname = data["object/file"][()].decode("utf-8")
        mesh_scale = data["object/scale"][()]
        mesh = trimesh.load(ci_data / mesh_fname, force="mesh").apply_scale(mesh_scale)
        assert T.shape == (len(success), 4, 4) and success.dtype.kind == "i"
        assert set(np.unique(success)) <= {0, 1}
        np.testing.assert_allclose(T[:, 3], np.tile([0, 0, 0, 1.0], (len(T), 1)))
        R = T[:, :3, :3]
        np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.tile(np.eye(3), (len(T), 1, 1)),
                                   atol=1e-5)  # fmt: skip
        for key in REQUIRED:
            assert key in data, (path, key)
        for k in ("linear", "angular"):
            for phase in ("closing", "shaking"):
                assert data[f"grasps/qualities/flex/object_motion_during_{phase}_{k}"].shape == (
                    len(T),)  # fmt: skip
        # A held grasp has its TCP at the object: within a hand's reach of its surface.
        from scipy.spatial import cKDTree

        held = T[success == 1, :3, 3]
        surface = trimesh.sample.sample_surface(mesh, 20000, seed=0)[0]
        dist, _ = cKDTree(surface).query(held)
        assert np.all(dist < 0.08), dist.max()
        # The hand frame's z axis is the approach of the candidate.
        np.testing.assert_allclose(T[:, :3, 2], data["symjax/approach"][()], atol=1e-5)
        assert data["gripper/type"][()].decode() == path.parent.name
        data.close()


def test_load_grasps_returns_typed_arrays(ci_data):
    doc = json.loads((ci_data / "manifest.json").read_text())
    for row in doc["shards"]:
        g = load_grasps(ci_data / row["file"])
        assert len(g) == row["n_grasps"] and g.success.dtype == bool
        assert int(g.success.sum()) == row["n_success"]
        assert g.labels["closed_joint_positions"].shape == (len(g), len(g.gripper["joint_names"]))
        assert g.generator_names == ("kth", "uji", "openrave", "dense")
        assert g.preshape_names == hands.PRESHAPES
        assert g.object["file"].endswith(".obj") and g.object["mass"] > 0
        # Held grasps closed on the object: their joints are not at the open pre-shape.
        q_open = np.asarray(g.gripper["configuration"])
        held = g.labels["closed_joint_positions"][g.success]
        assert np.all(np.abs(held - q_open).max(axis=1) > 1e-3)
        (v,) = g.views
        assert v.depth.shape == v.mask.shape and v.mask.any()
        assert v.points.shape[1] == 3 and v.completed.shape[0] >= v.points.shape[0]
        assert 0.0 <= v.confidence <= 1.0
        assert len(v.grasp_transforms) == len(v.true_success) == len(v.predicted_success)
        assert np.isfinite(v.plane).all()


def test_rerun_resumes_and_is_bit_identical(ci_data, tmp_path, capsys):
    """Delete one shard, truncate another, interrupt the rerun after its first shard: the
    complete shards are never touched, nothing half-written is left, and the recomputed shards
    carry the same labels bit for bit."""
    out = tmp_path / "copy"
    shutil.copytree(ci_data, out)
    files = _files(out)
    gone, cut = files[0], files[3]
    before = {f: f.read_bytes() for f in (gone, cut)}
    gone.unlink()
    cut.write_bytes(before[cut][: len(before[cut]) // 2])
    untouched = {f: f.stat().st_mtime_ns for f in files if f not in (gone, cut)}

    import symjax.data.shard as shard_mod

    real, calls = shard_mod.write_shard, []

    def interrupted(path, data, attrs):
        calls.append(path)
        if len(calls) == 2:
            raise KeyboardInterrupt
        real(path, data, attrs)

    shard_mod.write_shard = interrupted
    try:
        assert cli_main(["generate", "--config", "ci", "--out-dir", str(out)]) == 130
    finally:
        shard_mod.write_shard = real
    n = len(files)
    assert f"{n - 2} complete" in capsys.readouterr().out
    doc = json.loads((out / "manifest.json").read_text())
    assert doc["n_shards"] == n - 1 and not doc["complete"]
    assert not list(out.rglob(".*.tmp-*"))
    assert cli_main(["generate", "--config", "ci", "--out-dir", str(out)]) == 0
    assert f"{n - 1} complete" in capsys.readouterr().out
    assert {f: f.stat().st_mtime_ns for f in untouched} == untouched
    for f in (gone, cut):
        a, b = h5py.File(f, "r"), h5py.File(ci_data / f.relative_to(out), "r")
        for key in [k for k in KEYS if not k.startswith("views/")]:
            np.testing.assert_array_equal(a[key][()], b[key][()], err_msg=key)
        a.close()
        b.close()
    assert json.loads((out / "manifest.json").read_text())["complete"]


def test_disk_full_is_refused_before_work(tmp_path, monkeypatch):
    """A tiny quota folder (a 64 kB tmpfs where mounting works, a patched free-space reading
    elsewhere) gets a clear error before the first rollout."""
    quota = tmp_path / "quota"
    quota.mkdir()
    mounted = (
        os.geteuid() == 0
        and os.system(f"mount -t tmpfs -o size=64k tmpfs {quota} 2>/dev/null") == 0
    )
    if not mounted:
        import symjax.data.runner as runner

        monkeypatch.setattr(
            runner.shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(1, 1, 1000)
        )
    try:
        cfg = GenerateConfig.from_preset(CI, out_dir=str(quota / "data"))
        with pytest.raises(OutputError, match="MB free"):
            generate_dataset(cfg)
        assert not list((quota / "data").rglob("*.h5"))
    finally:
        if mounted:
            os.system(f"umount {quota}")


# --- the dense sampler --------------------------------------------------------------------------

_MUG = trimesh.creation.annulus(0.03, 0.045, 0.1, sections=24)
_MUG.apply_translation([0, 0, 0.05])


@settings(max_examples=5, deadline=None)
@given(
    n=st.integers(1, 150), seed=st.integers(0, 2**31 - 1), share=st.sampled_from([0.0, 0.5, 1.0])
)
def test_dense_candidates_start_clear_and_are_reproducible(n, seed, share):
    cfg = DenseSamplerConfig(antipodal_share=share)
    table = TablePlane.horizontal(0.0)
    hand = hands.load("sdh")
    c, drawn = dense_candidates(_MUG, n, config=cfg, table=table, hand=hand, seed=seed)
    assert len(c) == n and drawn >= n
    np.testing.assert_allclose(np.linalg.norm(c.approach, axis=1), 1.0, atol=1e-5)
    keep, _, _ = grasp.start_pose_check(c, _MUG, grasp.CandidateConfig(), table, hand)
    assert keep.all()
    again, _ = dense_candidates(_MUG, n, config=cfg, table=table, hand=hand, seed=seed)
    np.testing.assert_array_equal(c.point, again.point)
    np.testing.assert_array_equal(c.roll, again.roll)


def test_antipodal_candidates_close_across_the_object():
    """An antipodal candidate's closing axis lies along its chord: on a box, along an axis."""
    box = trimesh.creation.box([0.06, 0.04, 0.1])
    box.apply_translation([0, 0, 0.05])
    c, _ = dense_candidates(box, 200, config=DenseSamplerConfig(antipodal_share=1.0),
                            table=TablePlane.horizontal(0.0), seed=3)  # fmt: skip
    closing = np.asarray(c.frames())[:, :, 0]
    assert np.all(np.abs(closing).max(axis=1) > 0.999)  # a box's chords along its normals
    assert np.all(np.abs(np.einsum("ij,ij->i", closing, c.approach)) < 1e-4)
    # The start pose is outside the box along the approach.
    start = c.start_positions()
    assert np.all(np.abs(start - [0, 0, 0.05]).max(axis=1) > 0.02)


# --- Ray -----------------------------------------------------------------------------------------


@pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")  # Ray starts its raylet (fork+exec)
def test_ray_worker_killed_mid_run(tmp_path):
    """A local Ray cluster (2 CPUs): one worker is killed while its task runs; Ray retries it,
    the run completes and every shard is there exactly once."""
    pytest.importorskip("ray")
    spec = DatasetSpec(objects=("025_mug", "005_tomato_soup_can"), hands=("parallel_jaw",),
                       n_candidates=24, views=0)  # fmt: skip
    cfg = GenerateConfig.from_preset(CI, generate=spec, out_dir=str(tmp_path / "ray"))
    running = tmp_path / "ray" / ".running"
    killed: list[int] = []

    def killer():
        deadline = time.time() + 240
        while time.time() < deadline and not killed:
            for m in running.glob("*.json") if running.is_dir() else []:
                try:
                    pid = json.loads(m.read_text())["pid"]
                except (OSError, ValueError):
                    continue
                time.sleep(1.0)  # let the task get going
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
            time.sleep(0.2)

    t = threading.Thread(target=killer, daemon=True)
    t.start()
    doc = generate_dataset(cfg, use_ray=True, num_cpus=2, log=lambda s: None)
    t.join(timeout=5)
    assert killed, "no task was seen running"
    assert doc["complete"] and doc["n_shards"] == 2
    assert sorted(r["object"] for r in doc["shards"]) == ["005_tomato_soup_can", "025_mug"]
    assert len(_files(tmp_path / "ray")) == 2
    for f in _files(tmp_path / "ray"):
        assert len(load_grasps(f)) == 24


def test_mesh_folder_objects_take_their_scale(tmp_path):
    """A folder of meshes in millimetres, one scale each: the shard's mesh is in metres."""
    folder = tmp_path / "meshes_mm"
    folder.mkdir()
    box = trimesh.creation.box((50.0, 60.0, 110.0))  # millimetres
    box.export(folder / "box_mm.stl")
    spec = DatasetSpec(objects=(), mesh_folder=str(folder), scales=(("box_mm.stl", 0.001),),
                       hands=("parallel_jaw",), n_candidates=16, views=0)  # fmt: skip
    cfg = GenerateConfig.from_preset(CI, generate=spec, out_dir=str(tmp_path / "o"))
    doc = generate_dataset(cfg, log=lambda s: None)
    (row,) = doc["shards"]
    assert row["object"] == "box_mm" and row["scale"] == 0.001
    g = load_grasps(tmp_path / "o" / row["file"])
    mesh = trimesh.load(tmp_path / "o" / g.object["file"], force="mesh")
    np.testing.assert_allclose(sorted(mesh.extents), [0.05, 0.06, 0.11], atol=1e-6)
    assert g.object["mass"] == pytest.approx(400.0 * 0.05 * 0.06 * 0.11, rel=0.05)
