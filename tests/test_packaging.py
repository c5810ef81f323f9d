"""The package installs the way users install packages: a wheel carries the MJCF assets and the
presets, and the installed ``symjax`` command works outside the checkout."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_packages_list_names_every_subpackage():
    listed = set(
        tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    )
    found = {
        ".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "symjax").rglob("__init__.py")
    }
    assert found <= listed, f"missing from pyproject.toml: {sorted(found - listed)}"
    assert {"symjax.assets", "symjax.presets"} <= listed


def test_no_module_over_400_lines_and_no_shadowing_attribute():
    import importlib
    import pkgutil

    import symjax

    for path in (ROOT / "symjax").rglob("*.py"):
        n = len(path.read_text().splitlines())
        assert n <= 400, f"{path.relative_to(ROOT)} has {n} lines"
    for info in pkgutil.walk_packages(symjax.__path__, "symjax."):
        if info.name == "symjax.__main__":  # runs the command when imported
            continue
        mod = importlib.import_module(info.name)
        parent = importlib.import_module(info.name.rsplit(".", 1)[0])
        attr = parent.__dict__.get(info.name.rsplit(".", 1)[1])
        # A package attribute named like a submodule must be that module, not a function.
        assert attr is None or attr is mod, f"{info.name} is shadowed by {attr!r}"


def test_no_import_cycles():
    """Module-level symjax imports form a DAG (imports inside functions are deferred on purpose)."""
    graph: dict[str, set[str]] = {}
    for path in (ROOT / "symjax").rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        deps = set()
        for node in ast.parse(path.read_text()).body:
            if (
                isinstance(node, ast.ImportFrom)
                and node.module
                and node.module.startswith("symjax")
            ):
                deps.add(node.module)
            elif isinstance(node, ast.Import):
                deps |= {a.name for a in node.names if a.name.startswith("symjax")}
        graph[name] = deps

    def resolve(dep: str) -> str | None:
        while dep and dep not in graph:
            dep = dep.rpartition(".")[0]
        return dep or None

    state: dict[str, int] = {}

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for d in graph[node]:
            d = resolve(d)
            # A package's own __init__ importing its submodules is the package being built.
            if d is None or d == node or node.startswith(d + ".") or d.startswith(node + "."):
                continue
            if state.get(d) == 1:
                raise AssertionError("import cycle: " + " -> ".join([*stack, node, d]))
            if d not in state:
                visit(d, [*stack, node])
        state[node] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n, [])


def _site_packages(python: Path) -> Path:
    out = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return Path(out.stdout.strip())


@pytest.mark.slow
def test_wheel_installs_and_runs_outside_the_checkout(tmp_path):
    """Build the wheel, install it into a new virtualenv and use it from another folder.

    The dependencies (jax, mujoco, ...) are made visible to the new environment through a
    ``.pth`` line pointing at this environment's site-packages, so the test needs no download;
    symjax itself comes only from the wheel (checked below).
    """
    # Built from a copy: setuptools reuses an in-tree build/ folder, which may hold stale modules.
    src = tmp_path / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(
        ".venv", ".git", "build", "out", "*.egg-info", "__pycache__", ".pytest_cache",
    ))  # fmt: skip
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(src)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    (wheel,) = wheels.glob("symjax-*.whl")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    py = venv / "bin" / "python"
    subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(py), "install", "--no-deps", "-q",
         str(wheel)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    site = _site_packages(py)
    (site / "_symjax_test_deps.pth").write_text(str(_site_packages(Path(sys.executable))) + "\n")

    away = tmp_path / "elsewhere"
    away.mkdir()
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": ""}
    check = textwrap.dedent(
        f"""
        import math
        from pathlib import Path
        import symjax
        from symjax import configs, hands, robots
        from symjax.datasets.primitives import primitive_view
        installed = Path(symjax.__file__).resolve()
        assert installed.is_relative_to(Path({str(venv)!r}).resolve()), installed
        for name in hands.HAND_NAMES:
            hands.load(name).model()
        for name in robots.ROBOT_NAMES:
            robots.load(name).model()
        names = configs.preset_names()
        assert set(names) >= {{"paper", "default", "kth", "uji", "ci"}}, names
        for name in names:
            configs.load(name)
        obs, _ = primitive_view("box", math.radians(30), noise=0.001, seed=0)
        (cloud,) = symjax.complete(obs, configs.load("paper").symmetry)
        assert len(cloud) > obs.n_valid
        print("ok", len(names))
        """
    )
    out = subprocess.run([str(py), "-c", check], cwd=away, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.startswith("ok")

    exe = venv / "bin" / "symjax"
    for argv in (["--help"], ["eval", "--help"], ["eval", "--config", "paper", "--help"]):
        r = subprocess.run([str(exe), *argv], cwd=away, env=env, capture_output=True, text=True)
        assert r.returncode == 0, (argv, r.stderr[-2000:])
    assert "--symmetry.n-angles" in r.stdout and "(default: eigen)" in r.stdout
    # The paper preset end to end on one view of the embedded benchmark.
    r = subprocess.run(
        [str(exe), "eval", "--config", "paper", "--subset", "025_mug/000", "--gallery", "0",
         "--out-dir", str(away / "eval"), "--execution.no-progress"],
        cwd=away, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    assert "Mir7  mean deviation" in r.stdout
    assert (away / "eval" / "report.md").is_file()
