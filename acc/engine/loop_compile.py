"""Compiling the force loop for a configuration: once per machine, said once, and beside the
rest of the run's preparation where a second core is free.

A configuration's first run compiles :func:`acc.engine.force_loop.run_runs` (about 3 s) and,
while its records are built, every element's ``init`` (about 1 s).  Both are numba
compilations, which hold the interpreter: in one process they add up.
:func:`compiled_aside` builds the records once for their types only
(:func:`acc.engine.element.inits_skipped`), forks, and lets the child compile the loop into
numba's on-disk cache while this process builds the records for real (compiling the
``init`` functions); :func:`prepare_loop` then waits for the child and loads the loop from
the cache.  On two cores a cold ``acc run`` is about a second shorter.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import logging
import os
import signal
import sys
import threading
from collections.abc import Callable, Hashable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from acc.engine import force_loop
from acc.engine.element import exclusive_lock, inits_skipped, project_stamp


def prepare_loop(dispatcher: Any, args: tuple, what: Hashable) -> None:
    """Compile the loop for these arguments, or load it from the cache, before running it:
    one process at a time per configuration.

    Processes that need the same new configuration at once (the test workers, two commands,
    a cluster's workers sharing the cache) would each compile it, for seconds; under an
    exclusive file lock per configuration (and numba cache directory) the first compiles and
    writes numba's cache while the others wait, then load it.  The call that compiles runs
    no run (an empty run list).  Without ``fcntl`` (Windows) nothing is locked.
    """
    key = specialisation_key(args)
    if key in _READY:
        return
    _compile_locked(dispatcher, args, key, what)
    _READY.add(key)


@contextlib.contextmanager
def compiled_aside(
    dispatcher: Any, probe: Callable[[], tuple], what: Hashable
) -> Iterator[None]:
    """Compile the loop in a child process while the block runs (it builds the records).

    ``probe`` builds the loop's arguments; it is called under
    :func:`~acc.engine.element.inits_skipped`, for their types.  If that specialisation is
    neither loaded in this process nor compiled on this machine yet, a forked child compiles
    it (under :func:`prepare_loop`'s lock, so that no other process compiles it at the same
    time) and exits; leaving the block waits for the child, so that :func:`prepare_loop`
    loads what it wrote.  A block that raises stops the child first.

    Nothing is forked (and the block runs alone, as without it) where ``fork`` is not
    available, on one core, when this process runs other threads (a child of a threaded
    process may deadlock), when ``ACC_COMPILE_IN_PROCESS=1`` is set, or once this process
    has probed ``what`` (later batches of a sweep are not probed again).  A probe that
    raises forks nothing either: the block raises the same error where the records are
    built for real.  A child that fails leaves the compilation to :func:`prepare_loop`,
    which reports the error.
    """
    pid = _fork_compile(dispatcher, probe, what)
    if pid is None:
        yield
        return
    try:
        yield
    except BaseException:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)
        raise
    finally:
        with contextlib.suppress(ChildProcessError):
            os.waitpid(pid, 0)


def _fork_compile(dispatcher: Any, probe: Callable[[], tuple], what: Hashable) -> int | None:
    """Fork a child that compiles the probed specialisation; its pid, or None (nothing to
    compile, or no child possible: see :func:`compiled_aside`)."""
    if (
        not hasattr(os, "fork")
        or (os.cpu_count() or 1) < 2
        or threading.active_count() > 1
        or os.environ.get("ACC_COMPILE_IN_PROCESS") == "1"
        or what in _PROBED
    ):
        return None
    _PROBED.add(what)
    try:
        with inits_skipped():
            args = probe()
    except Exception:  # the real build raises it, with its one-line message
        return None
    key = specialisation_key(args)
    if key in _READY or _marker(key).exists():
        return None
    announce_compile(key, what)
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid:
        return pid
    code = 1  # pragma: no cover - the child (its coverage is not collected)
    try:  # pragma: no cover
        _compile_locked(dispatcher, args, key, None)
        code = 0
    finally:  # pragma: no cover - no exit handlers, no buffers flushed twice, no traceback
        os._exit(code)


def _compile_locked(dispatcher: Any, args: tuple, key: str, what: Hashable | None) -> None:
    """Compile (or load) the specialisation ``key`` under its lock, by a call on no run;
    ``what``: announce it (not in a child: its parent did)."""
    with exclusive_lock(_lock_path(key)):
        if what is not None:
            announce_compile(key, what)
        dispatcher(np.empty(0, dtype=np.int64), *args)


def specialisation_key(args: tuple) -> str:
    """The project's source stamp and the types of the loop's arguments, hashed: one key per
    compiled specialisation of the loop."""
    flat = [x for a in args for x in (a if isinstance(a, tuple) else (a,))]
    types = tuple(_dtype_text(a.dtype) for a in flat if isinstance(a, np.ndarray))
    return hashlib.sha1(repr((project_stamp(), types)).encode()).hexdigest()[:16]


@functools.lru_cache(maxsize=1024)
def _dtype_text(dtype: np.dtype) -> str:
    """``str(dtype)`` (a record's takes 0.1 ms to spell; a sweep asks it every chunk)."""
    return str(dtype)


def announce_compile(key: str, what: Hashable) -> None:
    """Say (logger ``acc``, INFO) when the loop specialisation ``key``
    (:func:`specialisation_key`) is about to be compiled, not loaded.

    A marker file per compiled specialisation, next to numba's cache and keyed by the
    project's source stamp and the records' types, tells a first compilation from a cache
    load; the marker is written here, before the call that compiles.
    """
    marker = _marker(key)
    if marker.exists():
        return
    kind = what[0] if isinstance(what, tuple) else what
    logging.getLogger("acc").info(
        "compiling the simulation engine for %r (once per configuration, a few seconds, "
        "cached on disk; `acc compile` compiles every kind at once)", kind,
    )
    try:
        marker.touch()
    except OSError:  # pragma: no cover - read-only cache: say it every time
        pass


#: Specialisations this process has compiled or loaded (:func:`prepare_loop`).
_READY: set[str] = set()

#: Configurations (:func:`acc.engine.simulate.engine_key`) this process has probed.
_PROBED: set[Hashable] = set()


def _marker(key: str) -> Path:
    return _marker_dir() / f"acc-compiled-{key}"


def _lock_path(key: str) -> Path:
    return _marker_dir() / f"acc-compiling-{key}.lock"


def _marker_dir() -> Path:
    """numba's cache directory for the loop: ``NUMBA_CACHE_DIR`` if set, else the
    ``__pycache__`` beside the engine's sources."""
    import numba

    configured = numba.config.CACHE_DIR
    d = Path(configured) if configured else Path(force_loop.__file__).parent / "__pycache__"
    try:
        d.mkdir(parents=True, exist_ok=True)
        if os.access(d, os.W_OK):
            return d
    except OSError:  # pragma: no cover
        pass
    fallback = Path.home() / ".cache" / "acc"  # pragma: no cover
    fallback.mkdir(parents=True, exist_ok=True)  # pragma: no cover
    return fallback  # pragma: no cover


__all__ = ["announce_compile", "compiled_aside", "prepare_loop", "specialisation_key"]
