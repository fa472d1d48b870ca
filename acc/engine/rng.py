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
``numpy.random.Generator(Philox(...)).standard_normal`` drawn from the same words (tested).
"""

from __future__ import annotations

import math

import numpy as np

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
_LOW32 = np.uint64(0xFFFFFFFF)
_S32 = np.uint64(32)
_S11 = np.uint64(11)
_ONE = np.uint64(1)


@jit
def _mulhilo(a: np.uint64, b: np.uint64) -> tuple:
    """High and low 64-bit words of the 128-bit product ``a * b``."""
    a_lo = a & _LOW32
    a_hi = a >> _S32
    b_lo = b & _LOW32
    b_hi = b >> _S32
    p0 = a_lo * b_lo
    p1 = a_lo * b_hi
    p2 = a_hi * b_lo
    p3 = a_hi * b_hi
    carry = ((p0 >> _S32) + (p1 & _LOW32) + (p2 & _LOW32)) >> _S32
    hi = p3 + (p1 >> _S32) + (p2 >> _S32) + carry
    return hi, a * b


@jit
def philox4x64(
    c0: np.uint64, c1: np.uint64, c2: np.uint64, c3: np.uint64, k0: np.uint64, k1: np.uint64
) -> tuple:
    """Philox4x64-10 of counter ``(c0, c1, c2, c3)`` under key ``(k0, k1)``: four words."""
    for i in range(10):
        if i > 0:
            k0 = k0 + _W0
            k1 = k1 + _W1
        hi0, lo0 = _mulhilo(_M0, c0)
        hi1, lo1 = _mulhilo(_M1, c2)
        c0, c1, c2, c3 = hi1 ^ c1 ^ k0, lo1, hi0 ^ c3 ^ k1, lo0
    return c0, c1, c2, c3


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
_S8 = np.uint64(8)
_TWO_M53 = 1.0 / 9007199254740992.0


@jit
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
        w0, w1, w2, w3 = philox4x64(
            st.block, st.stream, np.uint64(0), np.uint64(0), st.key0, st.key1
        )
        st.words[0] = w0
        st.words[1] = w1
        st.words[2] = w2
        st.words[3] = w3
        st.used = 0
    w = st.words[st.used]
    st.used += 1
    return w


@jit
def uniform(st) -> float:  # noqa: ANN001
    """The next uniform in [0, 1) of a stream: the top 53 bits of a word."""
    return float(next_word(st) >> _S11) * _TWO_M53


@jit
def normal(st) -> float:  # noqa: ANN001
    """The next standard normal of a stream (ziggurat; about one word per normal)."""
    while True:
        r = next_word(st)
        idx = r & _MASK8
        r = r >> _S8
        sign = r & _ONE
        rabs = (r >> _ONE) & _MASK52
        x = float(rabs) * _ZIG_W[idx]
        if sign == _ONE:
            x = -x
        if rabs < _ZIG_K[idx]:
            return x  # about 99.3 % of draws
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


@jit
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
