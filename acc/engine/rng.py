"""Counter-based normal streams (Philox4x64-10), drawn inside compiled code.

Every random number of a run comes from a *stream*: Philox4x64-10 (Salmon et al., "Parallel
random numbers: as easy as 1, 2, 3", SC'11) keyed by ``(seed, noise_id)`` and counted by
``(block, stream, 0, 0)``.  Block ``b`` of stream ``j`` gives four 64-bit words; standard normals
are drawn from the words by the ziggurat method (Marsaglia & Tsang 2000, in the 256-layer
form of NumPy's ``Generator.standard_normal``), about one word per normal.  So

* a run's numbers depend only on its seed, its noise id (by default its run number) and the
  stream, never on the batch, chunk, thread or backend it is simulated in;
* runs that share a seed and a noise id see the same numbers, whatever their controller:
  common random numbers for fair comparisons;
* nothing is drawn that is not used, and no generator object is created per run.

The words equal NumPy's ``numpy.random.Philox`` word for word, and the normals equal
``numpy.random.Generator(Philox(...)).standard_normal`` drawn from the same words, draw for
draw, to 1e-14 relative: the layer tables are computed here in double precision, NumPy's are
printed constants that differ in the last bits (tested in ``tests/test_rng.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from llvmlite import ir  # type: ignore[import-untyped]
from numba import types
from numba.core.extending import intrinsic

from acc.engine.element import jit

#: Record of one stream: Philox key and counter, and the unused words of the last block.
NORMAL_STREAM = np.dtype(
    [
        ("key0", "u8"),
        ("key1", "u8"),
        ("stream", "u8"),
        ("block", "u8"),
        ("words", "u8", (4,)),
        ("used", "i8"),
    ],
    align=True,
)

#: Stream numbers of the force loop (one per source of randomness of a run).
STREAM_FORCE_SENSOR = 0
STREAM_FEED_CURRENT = 1
STREAM_IDENTIFICATION = 2
STREAM_DISTURBANCE = 3

_M0 = np.uint64(0xD2E7470EE14C6C93)
_M1 = np.uint64(0xCA5A826395121157)
_W0 = np.uint64(0x9E3779B97F4A7C15)
_W1 = np.uint64(0xBB67AE8584CAA73B)
_S11 = np.uint64(11)
_ONE = np.uint64(1)


@intrinsic
def _mul128(typingctx, a, b):  # noqa: ANN001, ANN202 - numba intrinsic
    """High and low 64-bit words of the 128-bit product ``a * b`` of two uint64.

    One 128-bit multiplication in LLVM IR (on x86-64 a single ``mul`` giving both words),
    not four 32-bit partial products.
    """
    sig = types.UniTuple(types.uint64, 2)(types.uint64, types.uint64)

    def codegen(context, builder, signature, args):  # noqa: ANN001, ANN202
        i64, i128 = ir.IntType(64), ir.IntType(128)
        product = builder.mul(builder.zext(args[0], i128), builder.zext(args[1], i128))
        hi = builder.trunc(builder.lshr(product, ir.Constant(i128, 64)), i64)
        lo = builder.trunc(product, i64)
        return context.make_tuple(builder, signature.return_type, (hi, lo))

    return sig, codegen


#: ``_mulhilo(a, b) -> (hi, lo)`` in compiled code (the intrinsic's Python signature takes
#: numba's typing context first).
_mulhilo: Callable[[np.uint64, np.uint64], tuple[np.uint64, np.uint64]] = _mul128  # type: ignore[assignment]


@jit
def philox4x64(st) -> None:  # noqa: ANN001
    """Philox4x64-10 of the stream's counter ``(block, stream, 0, 0)`` under its key
    ``(key0, key1)``: the four words, written into ``st.words``.

    The words are stored one by one where they are computed: returned as a tuple, they were
    copied from the return slot into the record by one 32-byte load of four 8-byte stores,
    which the processor cannot forward (about 2 ns a plant step of a noisy run)."""
    c0 = st.block
    c1 = st.stream
    c2 = np.uint64(0)
    c3 = np.uint64(0)
    k0 = st.key0
    k1 = st.key1
    for i in range(10):
        if i > 0:
            k0 = k0 + _W0
            k1 = k1 + _W1
        hi0, lo0 = _mulhilo(_M0, c0)
        hi1, lo1 = _mulhilo(_M1, c2)
        c0, c1, c2, c3 = hi1 ^ c1 ^ k0, lo1, hi0 ^ c3 ^ k1, lo0
    st.words[0] = c0
    st.words[1] = c1
    st.words[2] = c2
    st.words[3] = c3


# --- the ziggurat (Marsaglia & Tsang 2000; 256 layers, 52-bit, as NumPy's Generator) -----
_ZIG_R = 3.6541528853610087963519472518
_ZIG_INV_R = 1.0 / _ZIG_R
_ZIG_AREA = 0.0049286732339746519


def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Layer tables ``k`` (acceptance bounds), ``w`` (width per unit) and ``f`` (density).

    The layer edges ``x`` satisfy ``x_i (f(x_{i-1}) - f(x_i)) = A`` with ``f(x) =
    exp(-x^2/2)``, the tail layer of area ``A`` beyond ``r``.
    """
    n = 256

    def pdf(x: float) -> float:
        return math.exp(-0.5 * x * x)

    x = np.zeros(n)
    x[0] = _ZIG_R
    for i in range(1, n - 1):
        x[i] = math.sqrt(-2.0 * math.log(pdf(x[i - 1]) + _ZIG_AREA / x[i - 1]))
    x = x[::-1]  # x[0] = 0 (top layer) ... x[255] = r
    scale = 2.0**52
    k = np.zeros(n, dtype=np.uint64)
    k[1:] = np.round(x[:-1] / x[1:] * scale).astype(np.uint64)
    k[0] = np.uint64(round(_ZIG_R * pdf(_ZIG_R) / _ZIG_AREA * scale))
    w = x / scale
    w[0] = _ZIG_AREA / pdf(_ZIG_R) / scale
    f = np.array([pdf(v) for v in x])
    return k, w, f


_ZIG_K, _ZIG_W, _ZIG_F = _ziggurat_tables()
_MASK52 = np.uint64(0x000FFFFFFFFFFFFF)
_MASK8 = np.uint64(0xFF)
_MASK9 = np.uint64(0x1FF)
_S8 = np.uint64(8)
_S9 = np.uint64(9)
#: The layer widths, then the same negated: indexed by the word's layer and sign bits.
_ZIG_SIGNED_W = np.concatenate([_ZIG_W, -_ZIG_W])
_TWO_M53 = 1.0 / 9007199254740992.0


@jit(python_entry=True)
def seed_stream(st, seed: int, noise_id: int, stream: int) -> None:  # noqa: ANN001
    """Point a :data:`NORMAL_STREAM` record at stream ``stream`` of ``(seed, noise_id)``.

    Its words are Philox4x64-10 of counters ``(1, stream, 0, 0), (2, stream, 0, 0), ...``
    under key ``(seed, noise_id)``: NumPy's ``Philox(key=(seed, noise_id),
    counter=(0, stream, 0, 0))`` gives the same words in the same order.
    """
    st.key0 = np.uint64(seed)
    st.key1 = np.uint64(noise_id)
    st.stream = np.uint64(stream)
    st.block = np.uint64(0)
    st.used = 4


@jit
def next_word(st) -> np.uint64:  # noqa: ANN001
    """The next 64-bit word of a stream (advances it)."""
    if st.used >= 4:
        st.block += _ONE
        philox4x64(st)
        st.used = 0
    w = st.words[st.used]
    st.used += 1
    return w


@jit
def uniform(st) -> float:  # noqa: ANN001
    """The next uniform in [0, 1) of a stream: the top 53 bits of a word."""
    return float(np.int64(next_word(st) >> _S11)) * _TWO_M53  # < 2**53: exact as int64


@jit
def _layer(st) -> tuple:  # noqa: ANN001
    """One ziggurat draw from the next word: layer, 52-bit magnitude, candidate ``x``."""
    r = next_word(st)
    idx = r & _MASK8
    rabs = (r >> _S9) & _MASK52
    # rabs < 2**52: a signed conversion, exact; bits 0-7 are the layer and bit 8 the sign,
    # so bits 0-8 index the widths with their sign (a product by -w is exactly the negated
    # product by w)
    x = float(np.int64(rabs)) * _ZIG_SIGNED_W[r & _MASK9]
    return idx, rabs, x


@jit(inline="always")
def normal(st) -> float:  # noqa: ANN001
    """The next standard normal of a stream (ziggurat; about one word per normal).

    The accepted draw (about 99.3 %) is returned here; the rest, which loops, is
    :func:`_normal_rejected`, called out of line: a short function with one predictable
    branch (8.5 ns a normal against 9.7 ns with the loop inline, one thread).  The short
    function is inlined into its callers (numba's ``inline="always"``; LLVM kept it a call,
    and a noisy plant step took 2 % longer).
    """
    idx, rabs, x = _layer(st)
    if rabs < _ZIG_K[idx]:
        return x
    return _normal_rejected(st, idx, rabs, x)


@jit
def _normal_rejected(st, idx: np.uint64, rabs: np.uint64, x: float) -> float:  # noqa: ANN001
    """Finish a ziggurat draw outside its layer's rectangle: the tail beyond ``r`` (layer
    0) or the wedge test; on rejection, draw again from the next word."""
    while True:
        if idx == 0:  # the tail beyond r
            while True:
                xx = -_ZIG_INV_R * math.log1p(-uniform(st))
                yy = -math.log1p(-uniform(st))
                if yy + yy > xx * xx:
                    if ((rabs >> _S8) & _ONE) == _ONE:
                        return -(_ZIG_R + xx)
                    return _ZIG_R + xx
        elif (_ZIG_F[idx - 1] - _ZIG_F[idx]) * uniform(st) + _ZIG_F[idx] < math.exp(
            -0.5 * x * x
        ):
            return x
        idx, rabs, x = _layer(st)
        if rabs < _ZIG_K[idx]:
            return x


@jit(python_entry=True)
def _fill(streams: np.ndarray, out: np.ndarray) -> None:
    st = streams[0]
    for i in range(out.shape[0]):
        out[i] = normal(st)


def normals(seed: int, noise_id: int, stream: int, n: int) -> np.ndarray:
    """The first ``n`` normals of a stream, shape (n,) (what compiled code draws in order)."""
    st = np.zeros(1, dtype=NORMAL_STREAM)
    seed_stream(st[0], seed, noise_id, stream)
    out = np.empty(n)
    _fill(st, out)
    return out


__all__ = [
    "NORMAL_STREAM",
    "STREAM_DISTURBANCE",
    "STREAM_FEED_CURRENT",
    "STREAM_FORCE_SENSOR",
    "STREAM_IDENTIFICATION",
    "next_word",
    "normal",
    "normals",
    "philox4x64",
    "seed_stream",
    "uniform",
]
