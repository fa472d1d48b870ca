"""A run's figures drawn in a second process while the first one simulates.

Importing matplotlib, laying out the figure and encoding the PNG take about as long as
everything else ``acc run`` does for one scenario (the imports, loading the compiled loop,
simulating, writing the tables).  :class:`FigureProcess` forks before the simulation: the
child imports matplotlib and :mod:`acc.plots` while the parent loads the compiled loop and
simulates; the parent then hands the result over a pipe and writes its tables while the
child draws and saves.  On two cores the command's wall time is the longer of the two
halves instead of their sum; the figures are the same files (drawn by the same functions).

Where ``fork`` is not available (Windows), the process runs other Python threads, the child
cannot be started, the result does not pickle or ``ACC_FIGURES_IN_PROCESS=1`` is set, the
figures are drawn in this process by :meth:`FigureProcess.wait`.  Any failure in the child
comes back as one line (:class:`acc.cli.common.CommandError`).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from acc.cli.common import CommandError

#: A figure to draw: (function of :mod:`acc.plots` taking ``(result, title=...)``, PNG path,
#: title).
FigureJob = tuple[str, Path, str]

#: Resolution of the saved figures [dots per inch].
DPI = 120


def draw_figures(result: Any, jobs: Sequence[FigureJob]) -> None:
    """Draw and save each job's figure (in the calling process)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acc import plots

    for name, path, title in jobs:
        fig = getattr(plots, name)(result, title=title)
        try:
            fig.savefig(path, dpi=DPI)
        finally:
            plt.close(fig)


def _portable(result: Any) -> tuple[type, dict[str, Any]]:
    """A result dataclass as its class and constructor arguments, read-only mappings as
    dicts (they do not pickle); the constructor freezes them again."""
    import dataclasses
    from types import MappingProxyType

    values = {}
    for f in dataclasses.fields(result):
        if f.init:
            v = getattr(result, f.name)
            values[f.name] = dict(v) if isinstance(v, MappingProxyType) else v
    return type(result), values


def import_plotting(modules: Sequence[str]) -> None:
    """Import matplotlib (the Agg backend) and pyplot, then ``modules`` (about 0.3 s)."""
    import importlib

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401

    for module in modules:
        importlib.import_module(module)


def _child(conn: Any, imports: Sequence[str]) -> None:  # pragma: no cover - forked process
    """The forked process: import the plotting stack, wait for the work, do it, report
    ``("ok", value)`` or ``("error", one line)``."""
    status = 0
    try:
        import_plotting(imports)  # the import is the point: done while waiting
        work = conn.recv()
        if work is not None:
            conn.send(("ok", _do(work)))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent in one line
        status = 1
        try:
            conn.send(("error", " ".join(f"{type(exc).__name__}: {exc}".split())))  # one line
        except (OSError, ValueError):
            pass
    finally:
        conn.close()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)


def _do(work: tuple[str, Any]) -> Any:
    """Do a piece of work handed over: ``("draw", (portable result, jobs))`` or
    ``("call", ("module:function", args))``; return what it returns."""
    kind, payload = work
    if kind == "draw":
        (cls, values), jobs = payload
        return draw_figures(cls(**values), jobs)
    target, args = payload
    return _function(target)(*args)


def _function(target: str) -> Any:
    """The function named ``"module:function"``."""
    import importlib

    module, _, name = target.partition(":")
    return getattr(importlib.import_module(module), name)


class FigureProcess:
    """Figures drawn in a forked process (see the module docstring); a context manager.

    ``with FigureProcess() as figures: ...; figures.draw(result, jobs); ...;
    figures.wait()``, or ``figures.call("module:function", *args)`` then ``figures.wait()``
    for the function's return value.  Leaving the block without :meth:`wait` (an error,
    Ctrl-C) ends the child.

    Parameters
    ----------
    imports : sequence of str
        Modules the child imports, after matplotlib, while it waits for the work.
    """

    def __init__(self, imports: Sequence[str] = ("acc.plots",)) -> None:
        self._imports = tuple(imports)
        self._pid: int | None = None
        self._conn: Any = None
        self._pending: tuple[Any, tuple] | None = None  # (function, args) to call here

    def __enter__(self) -> FigureProcess:
        import threading

        # a process with other Python threads (a test runner, a notebook) is not forked:
        # a lock one of them holds would stay locked in the child
        if (hasattr(os, "fork") and threading.active_count() == 1
                and os.environ.get("ACC_FIGURES_IN_PROCESS") != "1"):
            self._start()
        return self

    def _start(self) -> None:
        import warnings
        from multiprocessing.connection import Pipe

        parent, child = Pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        try:
            with warnings.catch_warnings():  # Python >= 3.12 warns of the BLAS pool's threads
                warnings.simplefilter("ignore", DeprecationWarning)
                pid = os.fork()
        except OSError:  # no process to spare: draw here
            parent.close()
            child.close()
            return
        if pid == 0:  # pragma: no cover - the child
            parent.close()
            _child(child, self._imports)
        child.close()
        self._pid, self._conn = pid, parent

    @property
    def forked(self) -> bool:
        """Whether a child process draws the figures (until it has reported)."""
        return self._pid is not None

    def draw(self, result: Any, jobs: Sequence[FigureJob]) -> None:
        """Hand the result and the figures over (the child draws them now); without a
        child they are drawn by :meth:`wait`."""
        if self._conn is not None:
            try:
                self._conn.send(("draw", (_portable(result), list(jobs))))
                return
            except Exception:  # noqa: BLE001 - not picklable, pipe gone: draw them here
                self._end(kill=True)
        self._pending = (draw_figures, (result, list(jobs)))

    def call(self, target: str, *args: Any) -> None:
        """Hand a call of the function ``target`` (``"module:function"``) over (the child
        calls it now); without a child it is called by :meth:`wait`."""
        if self._conn is not None:
            try:
                self._conn.send(("call", (target, args)))
                return
            except Exception:  # noqa: BLE001 - not picklable, pipe gone: call it here
                self._end(kill=True)
        self._pending = (_function(target), args)

    def wait(self) -> Any:
        """Wait until the work handed over is done; return what it returned.

        Raises
        ------
        CommandError
            It failed (the child's error, in one line), or the child ended without
            reporting.
        """
        if self._conn is None:
            if self._pending is None:
                return None
            function, args = self._pending
            self._pending = None
            return function(*args)
        try:
            status, value = self._conn.recv()
        except (EOFError, OSError):
            status, value = "error", "the figure process ended without saving the figures"
        self._end(kill=False)
        if status != "ok":
            raise CommandError(f"drawing the figures failed: {value}")
        return value

    def _end(self, kill: bool) -> None:
        """Close the pipe and reap the child (ended first when ``kill``: an error, Ctrl-C
        or no work; otherwise it has reported and is leaving)."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        if self._pid is not None:
            pid, self._pid = self._pid, None
            if kill:
                import signal

                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
            with contextlib.suppress(ChildProcessError):
                os.waitpid(pid, 0)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._end(kill=True)  # after wait() there is nothing left to end


__all__ = ["DPI", "FigureJob", "FigureProcess", "draw_figures", "import_plotting"]
