"""Every ``python`` and ``bash`` block of the README runs as written, in a fresh folder."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCKS = re.findall(r"```(python|bash)\n(.*?)```", (ROOT / "README.md").read_text(), re.S)


def test_readme_has_examples():
    kinds = [k for k, _ in BLOCKS]
    assert kinds.count("python") >= 4 and kinds.count("bash") >= 1


@pytest.mark.parametrize(
    "code", [c for k, c in BLOCKS if k == "python"], ids=lambda c: c.splitlines()[0][:40]
)
def test_python_block_runs(code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {"__name__": "__readme__"})


@pytest.mark.parametrize(
    "code", [c for k, c in BLOCKS if k == "bash"], ids=lambda c: c.splitlines()[0][:40]
)
def test_bash_block_runs(code, tmp_path, monkeypatch):
    """The block's first command through the installed console, the rest through
    ``symjax.cli.main`` in this process (what the console calls; a new interpreter per line cost
    5 s of imports each on the 2-core CI machine)."""
    from symjax.cli import main

    exe = Path(sys.executable).with_name("symjax")
    assert exe.is_file(), "the symjax console command is not installed in this environment"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    monkeypatch.chdir(tmp_path)
    for i, line in enumerate(code.strip().splitlines()):
        argv = shlex.split(line)
        assert argv[0] == "symjax", line
        if i == 0:
            r = subprocess.run(
                [str(exe), *argv[1:]], cwd=tmp_path, env=env, capture_output=True, text=True
            )
            assert r.returncode == 0, (line, r.stderr[-2000:])
        else:
            assert main(argv[1:]) == 0, line
