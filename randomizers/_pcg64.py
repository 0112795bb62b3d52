r"""numpy's PCG64 bit generator stepped inside compiled kernels (the words of ``random_raw``).

A kernel that needs many raw words (a 640x480 depth frame takes 153,600) spends about as long
in ``BitGenerator.random_raw`` as in its own work, and the words make a trip through memory.
Here the kernel steps the generator's state itself and hands the state back, so the stream is
the generator's own: the same words, in the same order, as ``random_raw`` would have given, and
the generator continues after them.

numpy's ``PCG64`` is O'Neill's PCG XSL-RR 128/64 (M. E. O'Neill, *PCG: A Family of Simple Fast
Space-Efficient Statistically Good Algorithms for Random Number Generation*, HMC-CS-2014-0905,
2014, Sect. 6.3.3; numpy docs, "Permuted Congruential Generator (64-bit, PCG64)"): a 128-bit
LCG :math:`s \leftarrow a s + c \bmod 2^{128}` with the multiplier
``a = 0x2360ED051FC65DA44385DF649FCCF645`` (the PCG reference implementation's default 128-bit
multiplier) and the odd increment ``c`` of the stream; each word is the output function of the
*new* state, :math:`\mathrm{rotr}_{64}(s_{hi} \oplus s_{lo},\ s \gg 122)`. Four words per
iteration come from the same state with :math:`s_{n+j} = a^j s_n + c\,(1 + a + \dots + a^{j-1})`,
so the four 128-bit multiply-adds do not wait for each other.

The state goes in and out through ``bit_generator.state`` (public API) under the generator's
lock; :func:`pcg64_state` reads it, :func:`put_pcg64_state` writes it back.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = [
    "JUMPS",
    "advance",
    "fill_raw",
    "is_pcg64",
    "pcg64_jumps",
    "pcg64_state",
    "put_pcg64_state",
]

#: PCG's default 128-bit LCG multiplier, as numpy's PCG64 uses it (O'Neill 2014; numpy pcg64.h).
MULTIPLIER = 0x2360ED051FC65DA44385DF649FCCF645
_MASK64 = (1 << 64) - 1
_MASK128 = (1 << 128) - 1
#: Words per iteration of the compiled loops (states :math:`s_{n+1} .. s_{n+4}` from :math:`s_n`).
JUMPS = 4


@intrinsic
def _mulhi(typingctx: Any, a: Any, b: Any) -> Any:  # pragma: no cover - compiled
    """High 64 bits of the 128-bit product of two uint64 (one ``mul`` on x86-64)."""
    sig = types.uint64(types.uint64, types.uint64)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        wide = ir.IntType(128)
        product = builder.mul(builder.zext(args[0], wide), builder.zext(args[1], wide))
        return builder.trunc(builder.lshr(product, ir.Constant(wide, 64)), ir.IntType(64))

    return sig, codegen


@numba.njit(inline="always")
def muladd(
    hi: np.uint64, lo: np.uint64, a_hi: np.uint64, a_lo: np.uint64, c_hi: np.uint64, c_lo: np.uint64
) -> tuple[np.uint64, np.uint64]:  # pragma: no cover - compiled
    """``(a * s + c) mod 2**128`` on 128-bit numbers given as (high, low) uint64 halves."""
    product = lo * a_lo
    new_lo = product + c_lo
    carry = np.uint64(new_lo < product)
    new_hi = hi * a_lo + lo * a_hi + _mulhi(lo, a_lo) + c_hi + carry  # type: ignore[call-arg]
    return new_hi, new_lo


@numba.njit(inline="always")
def output(hi: np.uint64, lo: np.uint64) -> np.uint64:  # pragma: no cover - compiled
    """PCG's XSL-RR output: the 64-bit xor of the halves rotated right by the top 6 bits."""
    x = hi ^ lo
    rot = hi >> np.uint64(58)
    return (x >> rot) | (x << ((np.uint64(64) - rot) & np.uint64(63)))


@numba.njit(cache=True, nogil=True)
def fill_raw(state: np.ndarray, jumps: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    """Fill ``out`` (uint64) with the next ``out.size`` words and advance ``state`` past them.

    ``state`` is ``[high, low]`` (uint64) and ``jumps`` the table of :func:`pcg64_jumps`; the
    words equal ``PCG64.random_raw(out.size)`` from the same state.
    """
    hi = state[0]
    lo = state[1]
    n = out.size
    i = 0
    while i + JUMPS <= n:
        h1, l1 = muladd(hi, lo, jumps[0, 0], jumps[0, 1], jumps[0, 2], jumps[0, 3])
        h2, l2 = muladd(hi, lo, jumps[1, 0], jumps[1, 1], jumps[1, 2], jumps[1, 3])
        h3, l3 = muladd(hi, lo, jumps[2, 0], jumps[2, 1], jumps[2, 2], jumps[2, 3])
        hi, lo = muladd(hi, lo, jumps[3, 0], jumps[3, 1], jumps[3, 2], jumps[3, 3])
        out[i] = output(h1, l1)
        out[i + 1] = output(h2, l2)
        out[i + 2] = output(h3, l3)
        out[i + 3] = output(hi, lo)
        i += JUMPS
    while i < n:
        hi, lo = muladd(hi, lo, jumps[0, 0], jumps[0, 1], jumps[0, 2], jumps[0, 3])
        out[i] = output(hi, lo)
        i += 1
    state[0] = hi
    state[1] = lo


@numba.njit(cache=True, nogil=True)
def advance(state: np.ndarray, jumps: np.ndarray, steps: int) -> None:  # pragma: no cover
    """Move ``state`` (``[high, low]``) ``steps`` words ahead in O(log steps) operations.

    The LCG's jump-ahead by squaring (F. B. Brown, *Random number generation with arbitrary
    strides*, Trans. Am. Nucl. Soc. 71, 1994): ``steps`` applications of :math:`s \to a s + c`
    are :math:`s \to A s + C`, built from the binary digits of ``steps``; numpy's
    ``PCG64.advance`` does the same.
    """
    zero = np.uint64(0)
    acc_ah, acc_al, acc_ch, acc_cl = zero, np.uint64(1), zero, zero  # the identity map
    cur_ah, cur_al, cur_ch, cur_cl = jumps[0, 0], jumps[0, 1], jumps[0, 2], jumps[0, 3]
    left = steps
    while left > 0:
        if left & 1:
            acc_ah, acc_al = muladd(acc_ah, acc_al, cur_ah, cur_al, zero, zero)
            acc_ch, acc_cl = muladd(acc_ch, acc_cl, cur_ah, cur_al, cur_ch, cur_cl)
        plus_one_l = cur_al + np.uint64(1)
        plus_one_h = cur_ah + np.uint64(plus_one_l == zero)
        cur_ch, cur_cl = muladd(cur_ch, cur_cl, plus_one_h, plus_one_l, zero, zero)
        cur_ah, cur_al = muladd(cur_ah, cur_al, cur_ah, cur_al, zero, zero)
        left >>= 1
    state[0], state[1] = muladd(state[0], state[1], acc_ah, acc_al, acc_ch, acc_cl)


def pcg64_jumps(increment: int) -> np.ndarray:
    r"""The multipliers and addends that take a state 1..4 steps ahead, for one stream.

    Parameters
    ----------
    increment : int
        The stream's LCG increment ``c`` (``bit_generator.state["state"]["inc"]``).

    Returns
    -------
    ndarray, uint64, shape (4, 4)
        Row ``j - 1`` holds :math:`a^j` and :math:`c (1 + a + \dots + a^{j-1})` (mod
        :math:`2^{128}`) as high, low, high, low.
    """
    table = np.empty((JUMPS, 4), dtype=np.uint64)
    a, c = 1, 0
    for j in range(JUMPS):
        a = (a * MULTIPLIER) & _MASK128
        c = (c * MULTIPLIER + increment) & _MASK128
        table[j] = (a >> 64, a & _MASK64, c >> 64, c & _MASK64)
    return table


def is_pcg64(bits: np.random.BitGenerator) -> bool:
    """True when ``bits`` is numpy's ``PCG64`` itself (not a subclass or another generator)."""
    return type(bits) is np.random.PCG64


def pcg64_state(bits: np.random.BitGenerator) -> tuple[dict[str, Any], np.ndarray, int]:
    """Read a ``PCG64``'s state: the state dict, ``[high, low]`` as uint64 and the increment."""
    full: dict[str, Any] = dict(bits.state)
    value = int(full["state"]["state"])
    return (
        full,
        np.array([value >> 64, value & _MASK64], dtype=np.uint64),
        int(full["state"]["inc"]),
    )


def put_pcg64_state(bits: np.random.BitGenerator, full: dict[str, Any], state: np.ndarray) -> None:
    """Write ``state`` (``[high, low]``) back into ``bits``; the rest of ``full`` is kept."""
    full["state"]["state"] = (int(state[0]) << 64) | int(state[1])
    bits.state = full
