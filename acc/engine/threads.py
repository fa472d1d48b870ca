"""Thread limits of the numerical libraries.

Small matrix computations (``scipy.linalg.expm`` inside ``cont2discrete``, a few-by-few
matrix) take milliseconds under OpenBLAS's default threading on a busy machine, against
microseconds on one thread; the project's commands and sweep workers therefore run BLAS on
one thread (their parallelism is the compiled loop's threads and the worker processes).
"""

from __future__ import annotations

import functools


@functools.cache
def limit_blas_threads() -> None:
    """Limit BLAS/OpenMP pools of this process to one thread (once; threadpoolctl)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)


__all__ = ["limit_blas_threads"]
