"""Jitted kernels kept as exported StableHLO beside JAX's persistent compilation cache.

JAX's persistent cache skips the compilation of a kernel a new process has seen before, but not
the Python tracing and the lowering to StableHLO that come first: for the symmetry search they
took 0.9-1.0 s of a new process's first view on the 2-core CPU, against 0.2 s of loading the
compiled program from the cache. A :class:`StoredKernel` exports each new signature once
(``jax.export``), stores it in ``<jax_compilation_cache_dir>/symjax-export``, and a later process
loads it and calls it without tracing; the persistent cache then supplies the compiled program.

Every call of a stored kernel goes through the exported program, whether it was just exported
or loaded, so a result does not depend on what the store held. A stored program is keyed by the
kernel, its static arguments, the argument shapes and dtypes, the JAX version and flags, the
backend and a digest of symjax's source: an edited kernel is exported again. Without a cache
directory (or with ``jax_enable_compilation_cache`` off) the kernel is a plain ``jax.jit``.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import pickle
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
import numpy as np

__all__ = ["StoredKernel", "store_dir"]

_LOG = logging.getLogger(__name__)
_FORMAT = 1  # bump when the stored layout changes


def store_dir() -> Path | None:
    """The folder of the exported kernels, or None when JAX keeps no persistent cache."""
    if not jax.config.jax_enable_compilation_cache:
        return None
    root = jax.config.jax_compilation_cache_dir
    return Path(root) / "symjax-export" if root else None


@functools.lru_cache(maxsize=1)
def _source_digest() -> str:
    """sha256 of symjax's Python sources (a few milliseconds, once per process)."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def _platform() -> str:
    """The backend, the versions and the flags that change what tracing produces."""
    dev = jax.devices()[0]
    flags = (jax.config.jax_enable_x64, jax.config.jax_default_matmul_precision)
    return f"{dev.platform}:{dev.device_kind}:{jax.__version__}:{jax.lib.__version__}:{flags}"


def _exported_call(name: str, exported, out_tree) -> Callable[[list], Any]:
    def call(*leaves):
        return exported.call(*leaves)

    call.__name__ = call.__qualname__ = name  # JAX's compile log names the kernel
    jitted = jax.jit(call)
    return lambda leaves: jax.tree_util.tree_unflatten(out_tree, jitted(*leaves))


class StoredKernel:
    """A function jitted with ``static_argnums``, its signatures exported and stored.

    Args:
        fn: The kernel (a pure function of arrays and hashable static arguments).
        static_argnums: Positions of the static arguments (as for ``jax.jit``).
        name: The kernel's name in the store (default ``fn.__name__``).
    """

    def __init__(self, fn: Callable, static_argnums: tuple[int, ...] = (), name: str = "") -> None:
        self.static_argnums = tuple(static_argnums)
        self.name = name or fn.__name__
        self.jit = jax.jit(fn, static_argnums=self.static_argnums)
        self._fn = fn
        self._calls: dict[Any, Callable[[list], Any]] = {}
        self._lock = threading.Lock()
        functools.update_wrapper(self, fn)

    def __call__(self, *args: Any) -> Any:
        folder = store_dir()
        if folder is None:
            return self.jit(*args)
        static = tuple(args[i] for i in self.static_argnums)
        dynamic = [a for i, a in enumerate(args) if i not in self.static_argnums]
        leaves, tree = jax.tree_util.tree_flatten(dynamic)
        avals = tuple((tuple(np.shape(x)), str(np.result_type(x))) for x in leaves)
        key = (static, tree, avals)
        call = self._calls.get(key)
        if call is None:
            with self._lock:  # threads asking for one new signature export it once
                call = self._calls.get(key)
                if call is None:
                    call = self._stored(folder, static, tree, avals, leaves)
                    self._calls[key] = call
        return call(leaves)

    def _args(self, static: tuple, dynamic: list) -> list:
        """The full argument list from the static and the dynamic ones."""
        it_s, it_d = iter(static), iter(dynamic)
        n = len(static) + len(dynamic)
        return [next(it_s) if i in self.static_argnums else next(it_d) for i in range(n)]

    def _stored(self, folder: Path, static, tree, avals, leaves) -> Callable[[list], Any]:
        ident = repr((_FORMAT, self.name, static, str(tree), avals, _platform(), _source_digest()))
        path = folder / f"{self.name.strip('_')}-{hashlib.sha256(ident.encode()).hexdigest()[:32]}"
        try:
            blob, out_tree = pickle.loads(path.read_bytes())
            return _exported_call(self.name, jax.export.deserialize(bytearray(blob)), out_tree)
        except FileNotFoundError:
            pass
        except Exception as e:  # a damaged or foreign file: exported again over it
            _LOG.debug("symjax: stored kernel %s unreadable (%s); exporting again", path, e)
        return self._export(path, static, tree, leaves)

    def _export(self, path: Path, static, tree, leaves) -> Callable[[list], Any]:
        from symjax._atomic import atomic_write_bytes
        from symjax.errors import SymjaxError

        out_trees: list = []

        def flat(*xs):
            dynamic = jax.tree_util.tree_unflatten(tree, list(xs))
            out, out_tree = jax.tree_util.tree_flatten(self._fn(*self._args(static, dynamic)))
            out_trees.append(out_tree)
            return out

        specs = [jax.ShapeDtypeStruct(np.shape(x), np.result_type(x)) for x in leaves]
        try:
            exported = jax.export.export(jax.jit(flat))(*specs)
            blob = bytes(exported.serialize())
        except Exception as e:  # not exportable here (say, flatbuffers missing): plain jit
            _LOG.debug("symjax: kernel %s not exported (%s); plain jit", self.name, e)
            return lambda xs: self.jit(*self._args(static, jax.tree_util.tree_unflatten(tree, xs)))
        try:
            atomic_write_bytes(path, pickle.dumps((blob, out_trees[-1])))
        except SymjaxError as e:  # a read-only cache: this process still calls the export
            _LOG.debug("symjax: kernel %s not stored (%s)", self.name, e)
        return _exported_call(self.name, exported, out_trees[-1])
