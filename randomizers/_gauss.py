r"""Fast i.i.d. standard-normal samples from a numpy ``Generator``'s bit stream (ziggurat).

numpy's ``Generator.standard_normal`` costs ~10 ns a sample on the project's CI machines, which
alone would exceed the per-step budget of a 64x64 depth image. This module draws raw 64-bit words
from the generator's own bit generator (so the stream stays seeded and reproducible) and turns
each 32-bit half into one normal sample with the ziggurat method of Marsaglia and Tsang
(J. Stat. Softw. 5(8), 2000), 256 layers, in a numba kernel.

Each 32-bit word ``u`` gives the layer ``u & 255``, the sign bit ``(u >> 8) & 1`` and a 23-bit
magnitude ``u >> 9``. About 98.8 % of the words are accepted at once; the rest go through the
exact wedge or tail test, which consumes further words. The output is exactly N(0, 1) up to the
23-bit resolution of the magnitude (steps of ``x_i / 2**23`` within layer ``i``).

Examples
--------
>>> import numpy as np
>>> out = np.empty(10_000, dtype=np.float32)
>>> z = fill_standard_normal(np.random.default_rng(0), out)
>>> bool(abs(z.mean()) < 0.05 and abs(z.std() - 1.0) < 0.05)
True
"""

from __future__ import annotations

import math

import numba
import numpy as np

from randomizers.errors import RandomizerTypeError

__all__ = [
    "ZIGGURAT_LAYERS",
    "NormalPool",
    "fill_standard_normal",
    "raw_words",
    "rectangle",
    "under_wedge",
    "ziggurat_tables",
]

#: Number of ziggurat layers (8 bits of each word select one).
ZIGGURAT_LAYERS = 256
# Right edge of the bottom layer for 256 layers (Marsaglia & Tsang 2000, Sect. 2).
_R = 3.6541528853610088
_MAG_BITS = 23
_MAG_SCALE = float(1 << _MAG_BITS)


def _density(x: float) -> float:
    return math.exp(-0.5 * x * x)


def ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    r"""Build the layer tables for the unnormalised density :math:`f(x) = e^{-x^2/2}`.

    Every layer has the area :math:`v = r f(r) + \int_r^\infty f = r f(r) +
    \sqrt{\pi/2}\,\mathrm{erfc}(r/\sqrt2)`. The right edges follow
    :math:`x_1 = r`, :math:`x_{i+1} = f^{-1}(f(x_i) + v / x_i)`; layer 0 is the base strip of width
    :math:`v / f(r)` (its part beyond ``r`` stands for the tail).

    Returns
    -------
    width : ndarray, float64, shape (256,)
        Right edge of each layer divided by ``2**23`` (so ``x = magnitude * width[i]``).
    accept : ndarray, uint32, shape (256,)
        Magnitudes below ``accept[i]`` lie entirely under the curve (accepted at once).
    fx : ndarray, float64, shape (257,)
        ``f`` at each right edge (``fx[256] = f(0) = 1``), for the wedge test.
    edge : ndarray, float64, shape (257,)
        The right edges themselves (``edge[0]`` is the base width, ``edge[256] = 0``).
    """
    n = ZIGGURAT_LAYERS
    area = _R * _density(_R) + math.sqrt(math.pi / 2.0) * math.erfc(_R / math.sqrt(2.0))
    edge = np.zeros(n + 1)
    edge[0] = area / _density(_R)
    edge[1] = _R
    for i in range(1, n - 1):
        edge[i + 1] = math.sqrt(-2.0 * math.log(_density(edge[i]) + area / edge[i]))
    edge[n] = 0.0
    fx = np.array([_density(x) for x in edge])
    fx[0] = _density(_R)  # the base strip's top is f(r)
    width = edge[:n] / _MAG_SCALE
    inner = edge[1 : n + 1]  # left-of-wedge limit of each layer (layer 0: r)
    accept = np.floor(inner / edge[:n] * _MAG_SCALE).astype(np.uint32)
    return width, accept, fx, edge


_WIDTH, _ACCEPT, _FX, _EDGE = ziggurat_tables()
_ACCEPT_I64 = _ACCEPT.astype(np.int64)
# Index 0..255: layer with a + sign, 256..511: the same layer with a - sign (bit 8 of a word).
_SIGNED_WIDTH = np.concatenate([_WIDTH, -_WIDTH])
_INV_2_32 = 1.0 / 4294967296.0
_CHUNK = 1 << 14  # samples per fast pass


@numba.njit(cache=True, nogil=True)
def _fast_pass(
    words: np.ndarray, out: np.ndarray, rejected: np.ndarray, width: np.ndarray, accept: np.ndarray
) -> int:  # pragma: no cover - compiled
    """Turn word ``i`` into ``out[i]`` branch-free; list the indices that need the slow test.

    ``width`` is the signed table (512 entries: layer and sign bit).
    """
    k = 0
    for i in range(out.size):
        u = np.int64(words[i])
        mag = u >> 9
        out[i] = float(mag) * width[u & 511]
        rejected[k] = i
        k += mag >= accept[u & 255]
    return k


@numba.njit(inline="always")
def rectangle(
    u: np.int64, width: np.ndarray, accept: np.ndarray
) -> tuple[np.int64, float, bool]:  # pragma: no cover - compiled
    """The ziggurat's first test of word ``u``: its layer (low 8 bits), its sample (magnitude
    ``u >> 9`` times the layer's width) and whether that lies inside the layer's rectangle
    (accepted at once)."""
    layer = u & 255
    mag = u >> 9
    return layer, float(mag) * width[layer], mag < accept[layer]


@numba.njit(inline="always")
def under_wedge(fx: np.ndarray, layer: np.int64, v: float, x: float) -> bool:  # pragma: no cover
    """The wedge test of sample ``x`` of ``layer`` (outside its rectangle) with a uniform ``v``
    in (0, 1): whether the point lies under the density."""
    return fx[layer] + v * (fx[layer + 1] - fx[layer]) < math.exp(-0.5 * x * x)


@numba.njit(cache=True, nogil=True)
def _slow_pass(
    words: np.ndarray,
    rejected: np.ndarray,
    start: int,
    out: np.ndarray,
    extra: np.ndarray,
    width: np.ndarray,
    accept: np.ndarray,
    fx: np.ndarray,
    r: float,
) -> int:  # pragma: no cover - compiled
    """Finish the rejected samples (wedge/tail tests, fresh words on rejection).

    Works through ``rejected[start:]`` using ``extra`` words; returns the position reached
    (an index is redone from its original word when ``extra`` runs out part-way).
    """
    m = extra.size
    p = 0
    for j in range(start, rejected.size):
        i = rejected[j]
        u = np.int64(words[i])
        while True:
            layer, x, inside = rectangle(u, width, accept)
            if inside:
                break
            if layer == 0:
                # Tail beyond r (Marsaglia 1964): repeat exponential proposals until the square
                # test passes (a tail rejection must not go back to the layer choice).
                while True:
                    if p + 2 > m:
                        return j
                    a = -math.log((float(extra[p]) + 0.5) * _INV_2_32) / r
                    b = -math.log((float(extra[p + 1]) + 0.5) * _INV_2_32)
                    p += 2
                    if b + b > a * a:
                        break
                x = r + a
                break
            else:
                if p + 1 > m:
                    return j
                v = (float(extra[p]) + 0.5) * _INV_2_32
                p += 1
                if under_wedge(fx, layer, v, x):
                    break
            if p + 1 > m:
                return j
            u = np.int64(extra[p])  # rejected: start again with a fresh word
            p += 1
        out[i] = -x if (u >> 8) & 1 else x
    return rejected.size


#: numpy's bit generators whose ``random_raw`` values carry 64 random bits (two 32-bit words).
_RAW64 = (np.random.PCG64, np.random.PCG64DXSM, np.random.Philox, np.random.SFC64)


def raw_words(bits: np.random.BitGenerator, count: int) -> np.ndarray:
    """At least ``count`` 32-bit words (uint32) of ``bits``' raw stream, in stream order.

    numpy's 64-bit generators (PCG64, PCG64DXSM, Philox, SFC64) give two words per raw value
    (``count`` rounded up to even); ``MT19937``'s raw values hold 32 bits each, one word per
    value (viewing them as two halves would make every other word 0). Any other bit generator
    is refused: its raw width is not known.

    Examples
    --------
    >>> import numpy as np
    >>> raw_words(np.random.PCG64(0), 3).size, raw_words(np.random.MT19937(0), 3).size
    (4, 3)
    """
    if isinstance(bits, _RAW64):
        return bits.random_raw((count + 1) // 2).view(np.uint32)
    if isinstance(bits, np.random.MT19937):
        return bits.random_raw(count).astype(np.uint32)
    raise RandomizerTypeError(
        f"the generator's bit generator is {type(bits).__name__}, whose raw output width is not "
        "known; the randomizers draw raw words from numpy's PCG64, PCG64DXSM, Philox, SFC64 or "
        "MT19937: seed the env with one of them (e.g. numpy.random.default_rng(seed))"
    )


def fill_standard_normal(rng: np.random.Generator, out: np.ndarray) -> np.ndarray:
    """Fill ``out`` (float32 or float64, C-contiguous) with i.i.d. N(0, 1) samples in place.

    The samples come from ``rng.bit_generator.random_raw`` (the generator's own stream), so the
    same seed gives the same samples. Returns ``out``.

    Examples
    --------
    >>> import numpy as np
    >>> a = fill_standard_normal(np.random.default_rng(1), np.empty(4, np.float32))
    >>> b = fill_standard_normal(np.random.default_rng(1), np.empty(4, np.float32))
    >>> bool((a == b).all())
    True
    """
    flat = out.reshape(-1)
    bits = rng.bit_generator
    rejected = np.empty(min(flat.size, _CHUNK), dtype=np.int64)
    # Chunks keep the raw words and the output in cache (and allocations small).
    for start in range(0, flat.size, _CHUNK):
        chunk = flat[start : start + _CHUNK]
        n = chunk.size
        words = raw_words(bits, n)
        k = _fast_pass(words, chunk, rejected, _SIGNED_WIDTH, _ACCEPT_I64)
        todo = rejected[:k]
        done = 0
        while done < k:
            extra = raw_words(bits, 4 * (k - done) + 16)
            done = _slow_pass(words, todo, done, chunk, extra, _WIDTH, _ACCEPT_I64, _FX, _R)
    return out


class NormalPool:
    """Serve i.i.d. N(0, 1) samples from a block refilled from a generator.

    Per-step noise on small arrays is dominated by call overhead; drawing a block at a time
    and handing out consecutive slices keeps every sample used once, in order, so the stream
    stays i.i.d. and reproducible. The block holds 64 requests of the first size asked for
    (between 1024 and 65536 samples) and grows to four times any larger request.
    :meth:`clear` drops the block (call it on reseeding).

    Examples
    --------
    >>> pool = NormalPool(np.float32)
    >>> rng = np.random.default_rng(0)
    >>> a = pool.take(rng, 10).copy()
    >>> pool.clear()
    >>> bool((a == pool.take(np.random.default_rng(0), 10)).all())
    True
    """

    def __init__(self, dtype: type[np.floating] | np.dtype) -> None:  # type: ignore[type-arg]
        self.dtype = np.dtype(dtype)
        self._buf = np.empty(0, dtype=self.dtype)  # allocated at the first take
        self._pos = 0

    def clear(self) -> None:
        """Forget the samples left in the block."""
        self._pos = self._buf.size

    def take(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Return ``n`` fresh samples (a view valid until the next call; do not keep it)."""
        if self._pos + n > self._buf.size:
            if self._buf.size < n:
                size = max(1024, min(1 << 16, 64 * n)) if self._buf.size == 0 else 4 * n
                self._buf = np.empty(max(size, n), dtype=self.dtype)
            fill_standard_normal(rng, self._buf)
            self._pos = 0
        view = self._buf[self._pos : self._pos + n]
        self._pos += n
        return view
