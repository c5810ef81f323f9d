"""Named presets, a user's TOML file, and the loader's typed errors."""

from __future__ import annotations

import dataclasses
import math

import pytest

from symjax import configs
from symjax.errors import ConfigError, FileFormatError, MissingFileError, UnknownNameError
from symjax.execution import ExecutionConfig
from symjax.symmetry import SymmetryConfig


def test_every_preset_loads_into_typed_configs():
    names = configs.preset_names()
    assert set(names) >= {"paper", "default", "kth", "uji", "ci"}
    for name in names:
        p = configs.load(name)
        assert p.description
        for section, cls in configs.SECTIONS.items():
            assert isinstance(getattr(p, section), cls), (name, section)
        # The evaluation is composed from the same tables: one home per value.
        assert p.evaluation.symmetry is p.symmetry and p.evaluation.execution is p.execution


def test_paper_preset_is_the_papers_search():
    p = configs.load("paper")
    s = p.symmetry
    assert (s.init, s.n_angles, s.n_shifts, s.n_refine) == ("eigen", 7, 5, 0)
    assert s.n_hypotheses == 35
    assert s.angle_range == pytest.approx(math.radians(20.0))
    assert p.evaluation.methods == ("Del", "Mir5", "Mir7")
    assert p.delaunay.n_samples == 500
    # Every view mirrored, as in the paper (no revolution, no fallback), and meshed as solved.
    assert p.completion.mode == "mirror" and p.evaluation.completion is p.completion
    assert not p.poisson.clip_to_hull and p.evaluation.poisson is p.poisson
    # Everything else is symjax's default: the default preset differs in the search, the
    # completion and the hull cut alone.
    d = configs.load("default")
    assert d.symmetry == SymmetryConfig() and d.symmetry != s
    assert d.completion.mode == "auto" and d.poisson.clip_to_hull
    paper_parts = dict(symmetry=s, completion=p.completion, poisson=p.poisson)
    assert dataclasses.replace(d.evaluation, **paper_parts) == p.evaluation


def test_gpu_preset_changes_only_how_work_is_split():
    g, d = configs.load("gpu"), configs.load("default")
    for section in configs.SECTIONS:
        if section != "execution":
            assert getattr(g, section) == getattr(d, section), section
    # The same resume keys and caches: a GPU run resumes a CPU run's folder and vice versa.
    assert g.evaluation.key() == d.evaluation.key()
    assert g.execution.eval_batch_size == g.execution.symmetry_chunk_views == 128


def test_platform_presets():
    kth, uji = configs.load("kth"), configs.load("uji")
    assert (kth.platform.robot, kth.platform.hand, kth.platform.generator) == ("kth", "sdh", "kth")
    assert (uji.platform.robot, uji.platform.hand, uji.platform.generator) == (
        "uji", "barrett", "uji",
    )  # fmt: skip
    assert kth.camera.baseline == pytest.approx(0.0915)
    assert uji.camera.fx < kth.camera.fx


def test_user_file_extends_and_overrides(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(
        'extends = "paper"\ndescription = "mine"\n[symmetry]\nn_angles = 9\n'
        "[execution]\neval_batch_size = 4\n"
    )
    p = configs.load(path)
    assert p.symmetry.n_angles == 9 and p.symmetry.init == "eigen"
    assert p.execution == ExecutionConfig(eval_batch_size=4)
    q = configs.load(path, overrides={"symmetry.n_shifts": 3, "symmetry": {"n_refine": 1}})
    assert (q.symmetry.n_angles, q.symmetry.n_shifts, q.symmetry.n_refine) == (9, 3, 1)


def test_execution_settings_do_not_change_the_result_key():
    a = configs.load("default").evaluation
    b = configs.load("default", {"execution.eval_batch_size": 3}).evaluation
    c = configs.load("paper").evaluation
    assert a.key() == b.key() != c.key()


@pytest.mark.parametrize(
    "overrides, error, needles",
    [
        ({"symmetry.n_angle": 7}, ConfigError, ["unknown key 'n_angle'", "n_angles"]),
        ({"symmetry.n_angles": "7"}, ConfigError, ["n_angles = '7'", "an integer"]),
        ({"symmetry.n_angles": 7.5}, ConfigError, ["n_angles = 7.5", "an integer"]),
        ({"symmetry.n_angles": 0}, ConfigError, ["n_angles", ">= 1", "got 0"]),
        ({"symmetry.w_outside": math.nan}, ConfigError, ["w_outside = nan", "finite"]),
        ({"symmetry.w_inside": math.inf}, ConfigError, ["w_inside = inf", "finite"]),
        ({"symmetry.init": "pca"}, ConfigError, ["init = 'pca'", "'eigen'", "'eigen+box'"]),
        ({"symmetry.normalize": True}, ConfigError, ["normalize = True", "'subset'"]),
        ({"candidates.distances": [0.1, "a"]}, ConfigError, ["distances[1] = 'a'"]),
        ({"candidates.distances": 0.1}, ConfigError, ["distances = 0.1", "a list of"]),
        ({"execution.progress": "yes"}, ConfigError, ["progress = 'yes'", "true or false"]),
        ({"execution.eval_batch_size": 0}, ConfigError, ["eval_batch_size", ">= 1", "got 0"]),
        ({"platform.hand": "barrett"}, ConfigError, ["hand = 'barrett'", "'sdh'"]),
        ({"platform.robot": "pr2"}, ConfigError, ["robot = 'pr2'", "'kth'", "'uji'"]),
        ({"evaluation.methods": ["Del", "Foo"]}, UnknownNameError, ["'Foo'", "Mir7"]),
        ({"evaluation.n_samples": 3}, ConfigError, ["n_samples", ">= 100", "got 3"]),
        ({"evaluation.symmetry": {}}, ConfigError, ["[symmetry] table"]),
        ({"bogus": 1}, ConfigError, ["unknown table or key 'bogus'", "symmetry"]),
        ({"symmetry": 3}, ConfigError, ["symmetry = 3", "a table"]),
        ({"poisson.depth": 12}, ConfigError, ["depth", "[2, 8]", "12"]),
    ],
)
def test_bad_values_name_the_key_the_value_and_what_is_accepted(overrides, error, needles):
    with pytest.raises(error) as e:
        configs.load("paper", overrides)
    for n in needles:
        assert n in str(e.value), (n, str(e.value))


def test_bad_files(tmp_path):
    with pytest.raises(UnknownNameError, match="unknown preset 'papr'.*paper"):
        configs.load("papr")
    with pytest.raises(MissingFileError, match="does not exist"):
        configs.load(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[symmetry\nn_angles = 3\n")
    with pytest.raises(FileFormatError, match="not valid TOML"):
        configs.load(bad)
    loop = tmp_path / "loop.toml"
    loop.write_text(f'extends = "{loop}"\n')
    with pytest.raises(ConfigError, match="cycle"):
        configs.load(loop)
