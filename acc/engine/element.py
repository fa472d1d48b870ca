"""The element protocol: every dynamic element's per-step law, written once and compiled.

An *element* is a plant, sensor, controller, estimator, observer or monitor.  It is defined
once, by

* a **params record** and a **state record**: numpy structured dtypes whose fields are named
  with their units (``bandwidth_rad_s``, ``integral``, ``history_mm_min``...).  Fixed-size
  arrays (filter matrices, ring buffers) are sub-array fields; their sizes come from the
  element's :meth:`Element.dtypes` (delay lines are rounded up to coarse powers of two, so a
  sweep over dead times compiles once, not once per dead time);
* ``init(p, s)``: a compiled function that sets the state record ``s`` from the params
  record ``p`` (the state before the first step);
* ``step(p, s, *inputs)``: the compiled per-step law; it updates ``s`` in place and returns
  the element's outputs.  What the inputs and outputs are is the contract of the *slot* the
  element fills (the controller slot: measured force in, override out; see
  :mod:`acc.engine.force_loop`).

Both functions are written with :func:`jit` and run unchanged for one run or for each run of
a batch: the loops of :mod:`acc.engine` call :func:`step` on ``params[r], state[r]``, and
:func:`step` dispatches at compile time on the params record's type to the element's own
``step``.  There is no second (NumPy) implementation of any law.

Compiled code is cached on disk (numba ``cache=True``).  Numba checks only the timestamp of
the file that holds a cached function, not of the files whose functions it inlines, so the
project installs its own cache locator: the freshness stamp of every cached function of the
project is the stamp of its file *and* of every source file of the packages ``acc``,
``plants`` and ``controllers``.  Editing any element recompiles what depends on it.
Elements defined outside those packages (e.g. in a test module) carry a hash of their own
module's source in their record's tag, so an edit there gives a new compiled specialisation.

This module imports only numpy and numba: plants and controllers build on it without
importing the rest of the engine.
"""

from __future__ import annotations

import contextlib
import contextvars
import hashlib
import inspect
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba
import numpy as np
from numba.core import caching, types
from numba.core.registry import CPUDispatcher
from numba.extending import overload

#: Packages whose sources make up the freshness stamp of cached compiled code.
_PACKAGES = ("acc", "plants", "controllers")
_ROOT = Path(__file__).resolve().parents[2]


def _tree_stamp() -> str:
    """A hash of (path, mtime, size) of every source file of the project's packages."""
    h = hashlib.sha1()
    for pkg in _PACKAGES:
        base = _ROOT / pkg
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames[:] = sorted(d for d in dirnames if not d.startswith((".", "__")))
            for name in sorted(filenames):
                if name.endswith(".py"):
                    path = os.path.join(dirpath, name)
                    st = os.stat(path)
                    h.update(f"{os.path.relpath(path, _ROOT)}:{st.st_mtime_ns}:{st.st_size};"
                             .encode())
    return h.hexdigest()


_STAMP: list[str] = []


def project_stamp() -> str:
    """Stamp of the project's source files (what cached compiled code is valid for)."""
    if not _STAMP:
        _STAMP.append(_tree_stamp())
    return _STAMP[0]


def _in_project(py_file: str) -> bool:
    try:
        rel = Path(py_file).resolve().relative_to(_ROOT)
    except ValueError:
        return False
    return rel.parts[0] in _PACKAGES


class _ProjectStampMixin:
    """Freshness stamp = the file's own stamp plus the whole project's source stamp."""

    def get_source_stamp(self) -> Any:
        return (super().get_source_stamp(), project_stamp())  # type: ignore[misc]

    @classmethod
    def from_function(cls, py_func: Callable, py_file: str) -> Any:
        if not _in_project(py_file):
            return None
        return super().from_function(py_func, py_file)  # type: ignore[misc]


class _ProjectUserProvidedLocator(_ProjectStampMixin, caching.UserProvidedCacheLocator):
    """``NUMBA_CACHE_DIR`` when it is set, project-wide freshness."""


class _ProjectInTreeLocator(_ProjectStampMixin, caching.InTreeCacheLocator):
    """``__pycache__`` next to the source, project-wide freshness."""


class _ProjectUserWideLocator(_ProjectStampMixin, caching.UserWideCacheLocator):
    """The user's cache directory (installed read-only), project-wide freshness."""


def _install_locators() -> None:
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    classes = getattr(impl, "_locator_classes", None)
    if classes is None or _ProjectInTreeLocator in classes:  # pragma: no cover
        return
    classes[0:0] = [_ProjectUserProvidedLocator, _ProjectInTreeLocator, _ProjectUserWideLocator]


_install_locators()


@contextlib.contextmanager
def exclusive_lock(path: Path) -> Iterator[None]:
    """Hold an exclusive ``flock`` on ``path`` (created) for the block: one process at a
    time compiles a configuration (:func:`acc.engine.loop_compile.prepare_loop`) or updates a
    cache index (:class:`_ProcessSafeCache`).  Nothing is locked where file locks are not
    available, the file cannot be opened or the file system refuses the lock (the processes
    then work side by side, as without it)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    try:
        fh = path.open("a")
    except OSError:  # pragma: no cover - read-only cache directory
        yield
        return
    with fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX)
        except OSError:  # pragma: no cover - a file system without locks (some NFS)
            yield
            return
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


class _ProcessSafeCache(caching.FunctionCache):
    """numba's on-disk cache of one function, its index updated by one process at a time.

    numba adds a compiled specialisation to a function's cache by reading the index file,
    adding the entry and writing the index back.  Two processes that compile two
    specialisations of one function at once (``acc compile`` on every core, the test
    workers) both read the index before either writes it: the later write drops the other's
    entry (and both may write the same data file), and that specialisation compiles again in
    every later process.  Here the read-add-write holds an exclusive ``flock`` on a lock file
    beside the index; without ``fcntl`` (Windows) or where the file system refuses the lock,
    the save is numba's own.
    """

    def save_overload(self, sig: Any, data: Any) -> None:
        with contextlib.suppress(OSError):  # a read-only cache: numba's save says so
            self._impl.locator.ensure_cache_path()
        with exclusive_lock(Path(self._cache_file._index_path + ".lock")):
            super().save_overload(sig, data)


class _PythonEntryCache(_ProcessSafeCache):
    """The cache of a function's Python-callable twin (:class:`_CompiledCallersDispatcher`):
    its entries share the function's index file under keys of their own."""

    def _index_key(self, sig: Any, codegen: Any) -> Any:
        return (*super()._index_key(sig, codegen), "python_entry")


def jit(fn: Callable | None = None, *, python_entry: bool = False, **options: Any) -> Any:
    """``numba.njit`` with the project's defaults: cached on disk, GIL released, and compiled
    for compiled callers only unless ``python_entry``.

    Use it for every per-step law and every compiled helper of an element.  The cache is
    safe for processes that compile the same function at once (:class:`_ProcessSafeCache`).

    numba compiles two wrappers with every function by default, and links them into every
    compiled caller's code, which optimises and emits them again: a C callback (for a
    function passed as a first-class function value, ``numba.types.FunctionType``, which the
    engine never does) and the Python entry.  Neither is compiled here, except the Python
    entry of a function declared ``python_entry=True`` (the loops and the other functions
    the engine calls from Python).  A call from Python to any other function still works: it
    goes to a twin compiled with the entry on its first such call (and cached on disk), for
    tests, notebooks and small tools (:class:`_CompiledCallersDispatcher`).  Without the C
    callback a cold compile of the shipped scenario took 0.6 s less (6.2 s against 6.8 s);
    without the Python entry too, about 1.1 s less again (4.8-5.2 s against 6.0-6.5 s).

    Parameters
    ----------
    fn : callable, optional
        The function (``@jit``); without it, a decorator (``@jit(...)``).
    python_entry : bool
        Compile the Python entry with the function: for functions called from Python on a
        production path.
    **options
        Further ``numba.njit`` options.
    """
    options = {"cache": True, "nogil": True, "no_cfunc_wrapper": True, **options}

    def wrap(f: Callable) -> Any:
        source = getattr(getattr(f, "__code__", None), "co_filename", "")
        cached = bool(options["cache"]) and os.path.exists(source)
        dispatcher = numba.njit(**{**options, "cache": False})(f)
        if not python_entry and isinstance(dispatcher, CPUDispatcher):  # not NUMBA_DISABLE_JIT
            dispatcher = _CompiledCallersDispatcher(
                dispatcher.py_func, dispatcher.locals,
                {**dispatcher.targetoptions, "no_cpython_wrapper": True},
            )
        if cached:  # what njit(cache=True) does, with the process-safe cache
            dispatcher._cache = _ProcessSafeCache(dispatcher.py_func)
        return dispatcher

    return wrap if fn is None else wrap(fn)


class _CompiledCallersDispatcher(CPUDispatcher):
    """A numba dispatcher whose compiled specialisations have no Python entry (see
    :func:`jit`): called from compiled code as any dispatcher, and from Python through a
    twin (the same function compiled with the entry, on the first call from Python, cached
    on disk under its own key: :class:`_PythonEntryCache`)."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        twin: Any = self.__dict__.get("_python_twin")
        if twin is None:
            options = {k: v for k, v in self.targetoptions.items() if k != "no_cpython_wrapper"}
            twin = CPUDispatcher(self.py_func, self.locals, options)
            if isinstance(getattr(self, "_cache", None), _ProcessSafeCache):
                twin._cache = _PythonEntryCache(self.py_func)
            self._python_twin = twin
        return twin(*args, **kwargs)


# --- records ---------------------------------------------------------------------------
def ring_size(needed: int) -> int:
    """Capacity of a small fixed-size array that must hold ``needed`` values (filter
    orders, teeth, segments, events): the next power of two, at least 8."""
    n = 8
    while n < needed:
        n *= 2
    return n


def delay_size(needed: int) -> int:
    """Capacity of a delay line, a moving window or a signal's pieces that must hold
    ``needed`` values: 256, 1024, 4096... (powers of four from 256).

    The capacity is part of the compiled loop's type: every size is one more compilation
    of the whole loop (seconds).  These buffers are read one slot per step, so a coarse,
    generous size costs a few kilobytes per run and no time per step, while one
    specialisation covers every dead time up to 255 steps (0.255 s at 1 ms), the next up
    to 1023 steps, and so on."""
    n = 256
    while n < needed:
        n *= 4
    return n


def per_run(*values: Any, dtype: Any = float) -> tuple[int, list[np.ndarray]]:
    """Values given per run or once, broadcast to one array each of shape ``(runs,)``.

    Returns ``runs`` (the longest length; scalars count 1) and the arrays (read-only views).
    """
    arrays = [np.atleast_1d(np.asarray(v, dtype=dtype)) for v in values]
    runs = max(a.size for a in arrays)
    return runs, [np.broadcast_to(a, (runs,)) for a in arrays]


@dataclass(frozen=True)
class Element:
    """One compiled element: its records and its compiled ``init`` and ``step``.

    Attributes
    ----------
    name : str
        Dotted name, ``slot.kind`` (e.g. ``"feed_drive.fopdt"``).
    dtypes : callable
        ``dtypes(**sizes) -> (params_dtype, state_dtype)``; the sizes are the element's
        sub-array sizes (ring capacities, filter orders), each keyword with a default.
    init : numba dispatcher
        ``init(p, s)``: sets the state record from the params record.
    step : numba dispatcher
        ``step(p, s, *inputs)``: one step of the law (contract of the element's slot).
    output : numba dispatcher or None
        ``output(p, s, *inputs)``: what the element shows at the start of a step, from its
        state, without advancing it (e.g. the force of the chip-load state); elements whose
        step returns everything have none.
    doc : str
        One line: what the element is, with its source (equation, paper).
    """

    name: str
    dtypes: Callable[..., tuple[np.dtype, np.dtype]]
    init: Any
    step: Any
    output: Any = None
    doc: str = ""

    @property
    def tag(self) -> str:
        """Name of the leading field that marks this element's records."""
        return _TAGS[self.name]

    def records(self, runs: int, **sizes: int) -> tuple[np.ndarray, np.ndarray]:
        """Zeroed params and state arrays of shape ``(runs,)`` for the given sizes."""
        p, s = self.dtypes(**sizes)
        return np.zeros(runs, dtype=p), np.zeros(runs, dtype=s)


#: name -> Element; tag field name -> Element.
_ELEMENTS: dict[str, Element] = {}
_BY_TAG: dict[str, Element] = {}
_TAGS: dict[str, str] = {}


def _module_hash(fn: Callable) -> str:
    try:
        source = inspect.getsource(sys.modules[fn.__module__])
    except (OSError, TypeError, KeyError):  # pragma: no cover
        source = fn.__qualname__
    return hashlib.sha1(source.encode()).hexdigest()[:10]


def _tag_for(name: str, step: Any) -> str:
    tag = "_element_" + name.replace(".", "__")
    py = getattr(step, "py_func", step)
    module = sys.modules.get(py.__module__)
    if module is None or not _in_project(getattr(module, "__file__", "") or ""):
        tag += "_" + _module_hash(py)
    return tag


def record(tag_of: str, fields: Sequence[tuple]) -> np.dtype:
    """A record dtype for element ``tag_of`` (its dotted name) with the given fields.

    The first field is the element's tag (one byte, unused), so that every element's
    records have a distinct type and :func:`step` can find the element from the type.
    Fields are ``(name, dtype)`` or ``(name, dtype, shape)`` as numpy takes them; nested
    records (another element's dtype) are allowed.
    """
    tag = _TAGS.get(tag_of)
    if tag is None:
        raise KeyError(f"element {tag_of!r} is not registered (register it before building)")
    return np.dtype([(tag, "u1"), *fields], align=True)


def register_element(
    name: str,
    dtypes: Callable[..., tuple[np.dtype, np.dtype]],
    init: Any,
    step: Any,
    doc: str = "",
    output: Any = None,
) -> Element:
    """Register a compiled element (see the module docstring) and return it.

    ``dtypes`` must build its records with :func:`record` ``(name, ...)``.  Registering the
    same name again with the same functions returns the existing element (module reloads).
    """
    if "." not in name:
        raise ValueError(f"element name must be 'slot.kind', got {name!r}")
    old = _ELEMENTS.get(name)
    if old is not None:
        same = getattr(old.step, "py_func", old.step).__qualname__ == getattr(
            step, "py_func", step
        ).__qualname__
        if not same:
            raise ValueError(f"element {name!r} is already registered")
    tag = _tag_for(name, step)
    _TAGS[name] = tag
    el = Element(name, dtypes, init, step, output, doc)
    _ELEMENTS[name] = el
    _BY_TAG[tag] = el
    p, s = dtypes()
    for dt, what in ((p, "params"), (s, "state")):
        if dt.names is None or dt.names[0] != tag:
            raise ValueError(f"element {name!r}: its {what} dtype must be built with record()")
    return el


def unregister_element(name: str) -> None:
    """Remove a registered element (tests, plugins); its compiled code stays cached."""
    el = _ELEMENTS.pop(name)
    _BY_TAG.pop(_TAGS.pop(name), None)
    del el


def elements() -> dict[str, Element]:
    """Every registered element by name (a copy)."""
    return dict(_ELEMENTS)


def element_of_type(tp: Any) -> Element:
    """The element whose records have numba type ``tp`` (a numba ``Record``)."""
    if not isinstance(tp, types.Record):
        raise TypeError(f"expected an element record, got {tp}")
    first = next(iter(tp.fields))
    el = _BY_TAG.get(first)
    if el is None:
        raise TypeError(f"record {tp} belongs to no registered element")
    return el


#: numba options of the dispatch overloads below.  Their ``apply`` is only ever called from
#: compiled code, so it needs neither the Python-callable wrapper nor the C callback one:
#: without them a cold compile of the shipped scenario's loop is about 0.3 s shorter
#: (19 overloads).  (numba's stub of ``jit_options``, ``_JITOptions``, omits these keys and
#: ``cache``, which ``overload`` passes on to ``njit``: hence ``Any``.)
_OVERLOAD_JIT: Any = {"cache": True, "no_cfunc_wrapper": True, "no_cpython_wrapper": True}


# --- compile-time dispatch ---------------------------------------------------------------
def step(p: Any, s: Any, *inputs: Any) -> Any:
    """One step of the element whose params record is ``p`` (compiled code only)."""
    raise NotImplementedError("acc.engine.element.step runs inside compiled code")


def output(p: Any, s: Any, *inputs: Any) -> Any:
    """The output of the element whose params record is ``p`` (compiled code only)."""
    raise NotImplementedError("acc.engine.element.output runs inside compiled code")


def init(p: Any, s: Any) -> None:
    """Initialise the state record ``s`` of the element whose params record is ``p``."""
    raise NotImplementedError("acc.engine.element.init runs inside compiled code")


# The typing functions below carry no annotations: numba compares their parameters with the
# implementations'.
@overload(step, jit_options=_OVERLOAD_JIT)
def _step_overload(p, s, *inputs):  # noqa: ANN001, ANN202
    impl = element_of_type(p).step

    def apply(p, s, *inputs):  # noqa: ANN001, ANN202
        return impl(p, s, *inputs)

    return apply


@overload(output, jit_options=_OVERLOAD_JIT)
def _output_overload(p, s, *inputs):  # noqa: ANN001, ANN202
    impl = element_of_type(p).output
    if impl is None:
        raise TypeError(f"element {element_of_type(p).name!r} has no output function")

    def apply(p, s, *inputs):  # noqa: ANN001, ANN202
        return impl(p, s, *inputs)

    return apply


@overload(init, jit_options=_OVERLOAD_JIT)
def _init_overload(p, s):  # noqa: ANN001, ANN202
    impl = element_of_type(p).init

    def apply(p, s):  # noqa: ANN001, ANN202
        impl(p, s)

    return apply


@jit(python_entry=True)
def _init_all(params: np.ndarray, state: np.ndarray) -> None:
    for r in range(params.shape[0]):
        init(params[r], state[r])


@jit(python_entry=True)
def _step_at(params: np.ndarray, state: np.ndarray, r: int, inputs: tuple) -> Any:
    return step(params[r], state[r], *inputs)


@jit(python_entry=True)
def _output_at(params: np.ndarray, state: np.ndarray, r: int, inputs: tuple) -> Any:
    return output(params[r], state[r], *inputs)


@numba.njit(nogil=True)
def _call_at(fn: Any, params: np.ndarray, state: np.ndarray, r: int, inputs: tuple) -> Any:
    return fn(params[r], state[r], *inputs)


def call_runs(
    fn: Any, params: np.ndarray, state: np.ndarray, *inputs: Any, shared: tuple = ()
) -> Any:
    """Call a compiled function ``fn(p, s, *inputs)`` of an element on every run from
    Python (e.g. an observer's ``estimate``); shapes as :func:`step_runs`.  For tests and
    small tools: each call compiles for its function (not cached on disk)."""
    return _per_run(
        lambda p, st, r, args: _call_at(fn, p, st, r, args), params, state, inputs, shared
    )


def init_states(params: np.ndarray, state: np.ndarray) -> np.ndarray:
    """Run the element's compiled ``init`` on every run; returns ``state`` (set in place).

    Inside :func:`inits_skipped` nothing runs (nor compiles): the state is left as
    allocated."""
    if not _INITS_SKIPPED.get():
        _init_all(params, state)
    return state


#: Whether :func:`init_states` runs the compiled ``init`` (see :func:`inits_skipped`).
_INITS_SKIPPED: contextvars.ContextVar[bool] = contextvars.ContextVar(
    "acc_inits_skipped", default=False
)


@contextlib.contextmanager
def inits_skipped() -> Iterator[None]:
    """Build records without initialising their states, for their types only: a loop's
    specialisation is known (and can be compiled elsewhere) before the ``init`` functions
    compile (:func:`acc.engine.loop_compile.compiled_aside`)."""
    token = _INITS_SKIPPED.set(True)
    try:
        yield
    finally:
        _INITS_SKIPPED.reset(token)


def _per_run(
    fn: Any, params: np.ndarray, state: np.ndarray, inputs: tuple, shared: tuple
) -> Any:
    runs = params.shape[0]
    columns = [np.broadcast_to(np.asarray(x), (runs,)) for x in inputs]
    outs = [
        fn(params, state, r, tuple(c[r].item() for c in columns) + tuple(shared))
        for r in range(runs)
    ]
    if outs and isinstance(outs[0], tuple):
        return tuple(np.array(col) for col in zip(*outs, strict=True))
    if all(o is None for o in outs):
        return None
    return np.array(outs)


def output_runs(
    params: np.ndarray, state: np.ndarray, *inputs: Any, shared: tuple = ()
) -> Any:
    """Every run's element output from Python (for tests and small tools); see
    :func:`step_runs` for shapes.  The state is not changed."""
    return _per_run(_output_at, params, state, inputs, shared)


def step_runs(params: np.ndarray, state: np.ndarray, *inputs: Any, shared: tuple = ()) -> Any:
    """Advance every run one step from Python (for tests and small tools, not hot loops).

    Parameters
    ----------
    params, state : ndarray of records, shape (runs,)
        The state is updated in place.
    *inputs : array_like, each shape (runs,) or scalar
        The step's inputs, per run.
    shared : tuple
        Further inputs passed as they are to every run's step, after the per-run ones
        (e.g. a diagnostics buffer).

    Returns
    -------
    ndarray or tuple of ndarray, each shape (runs,), or None
        The step's outputs per run (a tuple when the step returns several; None when it
        returns nothing).
    """
    return _per_run(_step_at, params, state, inputs, shared)


__all__ = [
    "Element",
    "call_runs",
    "delay_size",
    "element_of_type",
    "elements",
    "exclusive_lock",
    "init",
    "init_states",
    "inits_skipped",
    "jit",
    "output",
    "output_runs",
    "per_run",
    "project_stamp",
    "record",
    "register_element",
    "ring_size",
    "step",
    "step_runs",
    "unregister_element",
]
