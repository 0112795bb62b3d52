"""Additive sensor noise: any Box entry, depth images and lidar scans.

The dense noise (one draw per element and step) comes from
:func:`randomizers._gauss.fill_standard_normal` on the wrapper's own generator; it is not copied
into ``info`` (that would double the observation's memory) but is reproducible from the seed.
``info["randomization"][name]`` holds the effective standard deviation (and the number of
dropped lidar beams).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numba
import numpy as np

from randomizers._base import check_nonnegative, check_number
from randomizers._dynamics import check_spread
from randomizers._gauss import (
    _ACCEPT_I64,
    _FX,
    _INV_2_32,
    _R,
    _SIGNED_WIDTH,
    _WIDTH,
    _slow_pass,
    raw_words,
    rectangle,
    under_wedge,
)
from randomizers._lidar_sysid import FromSensors, SensorNoiseDistribution, load_sensor_noise
from randomizers._observation import ObservationRandomizer
from randomizers._pcg64 import (
    JUMPS,
    advance,
    fill_raw,
    is_pcg64,
    muladd,
    output,
    pcg64_jumps,
    pcg64_state,
    put_pcg64_state,
)
from randomizers._select import select
from randomizers.errors import RandomizerValueError

__all__ = ["DepthNoise", "LidarNoise", "ObservationNoise"]

# The ziggurat's acceptance limits as int32 (magnitudes are 23-bit) for the fused depth kernel.
_ACCEPT_I32 = _ACCEPT_I64.astype(np.int32)
# The same twice over, indexed like _SIGNED_WIDTH by layer and sign bit (one mask for both).
_SIGNED_ACCEPT_I32 = np.concatenate([_ACCEPT_I32, _ACCEPT_I32])
# Pixels per block of the PCG64 depth kernel: the block's samples stay in L1 between the scalar
# ziggurat pass and the vectorised add (a multiple of 2 * JUMPS: whole iterations of four words).
_DEPTH_BLOCK = 4096


class ObservationNoise(ObservationRandomizer):
    r"""Add i.i.d. Gaussian noise :math:`\mathcal N(0, (c\,\sigma)^2)` to a Box observation entry.

    The generic sensor-noise wrapper: one std for the entry, or one per element of the last
    axis. Values are clipped to the entry's Box bounds when ``clip`` is True (default), so
    the observation stays in its space.

    Parameters
    ----------
    env : gymnasium.Env
        Env with a float ``Box`` observation, or a ``Dict`` holding one.
    std : float or sequence of float
        Noise standard deviation σ in the entry's units (>= 0); a sequence gives one per element
        of the selected last axis.
    key : str, optional
        Dict key of the entry (required for Dict spaces).
    index : int, slice or [start, stop], optional
        Range of the last axis to perturb (default: all of it).
    clip : bool
        Clip to the entry's bounds after adding the noise.
    scale : float
        Curriculum scale c in [0, 1] multiplying σ.
    name : str, optional
        Unique name in the stack (random stream and info key); default ``ObservationNoise`` plus
        the key/index, e.g. ``ObservationNoise[2:4]``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> from randomizers import ObservationNoise
    >>> env = ObservationNoise(gym.make("CartPole-v1"), std=0.01, index=[2, 4])
    >>> obs, info = env.reset(seed=0)
    >>> info["randomization"]["ObservationNoise[2:4]"]
    {'std': 0.01, 'scale': 1.0}
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        std: float | Sequence[float] = 0.1,
        *,
        key: str | None = None,
        index: Any = None,
        clip: bool = True,
        scale: float = 1.0,
        name: str | None = None,
    ) -> None:
        sel = select(env.observation_space, key=key, index=index, wrapper="ObservationNoise")
        std_value = _check_std(std, sel.shape[-1] if sel.shape else 1, argument="std")
        _check_std_scale(std_value, sel.low, sel.high, sel.dtype, "ObservationNoise", "std")
        self._wrap_selection(
            env,
            sel,
            scale=scale,
            name=name,
            std=std_value if isinstance(std_value, float) else std_value.tolist(),
            options={"clip": bool(clip)},
        )
        self._std = std_value
        self._clip = bool(clip)

    def _effective_std(self) -> float | np.ndarray:
        return self.scale * self._std

    def observation(self, observation: Any) -> Any:
        """Return ``observation`` with noise added to the selected entry (a new object)."""
        part = self._sel.get(observation)
        z = self._standard_normal(part.size).reshape(part.shape)
        out = np.empty(part.shape, dtype=self._sel.dtype)
        np.multiply(z, self._effective_std(), out=out, casting="unsafe")
        out += part
        if self._clip:
            self._sel.clip(out)
        return self._sel.put(observation, out)

    def episode_record(self) -> dict[str, Any]:
        """Effective std and scale."""
        return self.step_record()

    def step_record(self) -> dict[str, Any]:
        """Effective std and scale (the per-element noise is reproducible from the seed)."""
        std = self._effective_std()
        return {"std": std if isinstance(std, float) else std.tolist(), "scale": self.scale}


@numba.njit(cache=True, nogil=True)
def _depth_samples(
    words: np.ndarray, z: np.ndarray, rejected: np.ndarray, width: np.ndarray, accept: np.ndarray
) -> int:  # pragma: no cover - compiled
    """``z[i]`` = the ziggurat fast-pass sample of word ``i`` in ``z``'s precision (as
    :func:`randomizers._gauss.fill_standard_normal` maps words to samples; ``width`` comes in
    that dtype). Lists the pixels whose word needs the slow test (about 1.2 %) in ``rejected``
    and returns their count; :func:`_noisy_depth_fix` redoes them.

    The table look-ups keep this loop scalar; the noise itself is added by the vectorised
    :func:`_noisy_depth_add`.
    """
    k = 0
    for i in range(z.size):
        u = words[i]
        mag = np.int32(u >> np.uint32(9))
        z[i] = z.dtype.type(mag) * width[u & np.uint32(511)]
        if mag >= accept[u & np.uint32(255)]:
            rejected[k] = i
            k += 1
    return k


@numba.njit(cache=True, nogil=True)
def _noisy_depth_add(
    img: np.ndarray, z: np.ndarray, out: np.ndarray, std: float, near: float, far: float
) -> None:  # pragma: no cover - compiled
    """Valid pixels: ``out = clip(img + std * z, near, far)``; invalid ones are copied.

    In the image's precision (``z``, ``std``, ``near`` and ``far`` come in its dtype); no
    look-ups or stores that depend on the data, so it compiles to SIMD code.
    """
    zero = img.dtype.type(0.0)
    for i in range(img.size):
        d = img[i]
        v = min(max(d + std * z[i], near), far)
        # NaN and +-inf fail one of the two tests
        out[i] = v if (d > zero) & (d < far) else d


@numba.njit(cache=True, nogil=True)
def _noisy_depth_fix(
    img: np.ndarray,
    z: np.ndarray,
    out: np.ndarray,
    pixels: np.ndarray,
    std: float,
    near: float,
    far: float,
) -> None:  # pragma: no cover - compiled
    """Redo ``out`` at ``pixels`` with their finished samples (``z[j]`` for ``pixels[j]``)."""
    for j in range(pixels.size):
        i = pixels[j]
        d = img[i]
        if d > 0.0 and d < far:
            out[i] = min(max(d + std * z[j], near), far)


#: A PCG64 stream of 32-bit halves: state (``hi``, ``lo``), the current 64-bit ``word`` and
#: whether its high half is still unused.
_Halves = tuple[np.uint64, np.uint64, np.uint64, bool]
#: One step of the state, ``(a_hi, a_lo, c_hi, c_lo)``: its multiplier and increment.
_Step = tuple[np.uint64, np.uint64, np.uint64, np.uint64]


@numba.njit(inline="always")
def _next_half(stream: _Halves, step: _Step) -> tuple[np.uint32, _Halves]:  # pragma: no cover
    """The next 32-bit half of a PCG64 stream, low half first (as ``view(np.uint32)`` orders
    them on a little-endian machine), and the stream after it. Scalars only: no array
    reference counting in the slow path's inner loop.
    """
    hi, lo, word, high_left = stream
    if high_left:
        return np.uint32(word >> np.uint64(32)), (hi, lo, word, False)
    hi, lo = muladd(hi, lo, step[0], step[1], step[2], step[3])
    word = output(hi, lo)
    return np.uint32(word & np.uint64(0xFFFFFFFF)), (hi, lo, word, True)


@numba.njit(cache=True, nogil=True)
def _finish_sample(
    u: np.int64, stream: _Halves, step: _Step
) -> tuple[float, _Halves, int]:  # pragma: no cover - compiled
    """:func:`randomizers._gauss._slow_pass` for one rejected word ``u``, the further words
    taken from the stream of :func:`_next_half` instead of an array (the same tests in the same
    order); returns the sample, the stream after it and how many halves it took."""
    used = 0
    while True:
        layer, x, inside = rectangle(u, _WIDTH, _ACCEPT_I64)
        if inside:
            break
        if layer == 0:  # the tail beyond r (see _slow_pass)
            while True:
                h, stream = _next_half(stream, step)
                a = -math.log((float(h) + 0.5) * _INV_2_32) / _R
                h, stream = _next_half(stream, step)
                b = -math.log((float(h) + 0.5) * _INV_2_32)
                used += 2
                if b + b > a * a:
                    break
            x = _R + a
            break
        h, stream = _next_half(stream, step)
        v = (float(h) + 0.5) * _INV_2_32
        used += 1
        if under_wedge(_FX, layer, v, x):
            break
        h, stream = _next_half(stream, step)
        u = np.int64(h)  # rejected: start again with a fresh word
        used += 1
    return (-x if (u >> 8) & 1 else x), stream, used


@numba.njit(cache=True, nogil=True)
def _noisy_depth_pcg64(
    state: np.ndarray,
    jumps: np.ndarray,
    img: np.ndarray,
    out: np.ndarray,
    z: np.ndarray,
    rejected: np.ndarray,
    first: np.ndarray,
    scratch: np.ndarray,
    order: np.ndarray,
    width: np.ndarray,
    accept: np.ndarray,
    std: float,
    near: float,
    far: float,
) -> int:  # pragma: no cover - compiled
    """The whole frame from a PCG64 state (:mod:`randomizers._pcg64`); returns the rejections.

    The same numbers as the ``random_raw`` path of :meth:`DepthNoise._noisy`: word ``i`` of
    the frame (two samples per 64-bit word, low half first as ``view(np.uint32)`` orders them
    on a little-endian machine) is stepped here instead of read from memory, ``z.size`` pixels
    at a time: the ziggurat fast pass of :func:`_depth_samples` into ``z`` (the block's
    samples, in the image's precision), then :func:`_noisy_depth_add` on the block. The
    block's rejected samples are finished at once by :func:`_finish_sample` with the words
    after the frame's (a second stream, jumped ahead), in pixel order as
    :func:`randomizers._gauss._slow_pass` finishes them, and their pixels redone by
    :func:`_noisy_depth_fix`. The ``random_raw`` path draws those words in a batch of
    ``2 k + 8`` for ``k`` rejections: ``state`` ends after that batch, and in the rare frame
    that would need more than one batch the rejected samples (index and word kept in
    ``rejected``, ``first``) are redone batch by batch exactly as that path does.
    """
    ftype = img.dtype.type
    std_f, near_f, far_f = ftype(std), ftype(near), ftype(far)
    hi = state[0]
    lo = state[1]
    a1h, a1l, c1h, c1l = jumps[0, 0], jumps[0, 1], jumps[0, 2], jumps[0, 3]
    a2h, a2l, c2h, c2l = jumps[1, 0], jumps[1, 1], jumps[1, 2], jumps[1, 3]
    a3h, a3l, c3h, c3l = jumps[2, 0], jumps[2, 1], jumps[2, 2], jumps[2, 3]
    a4h, a4l, c4h, c4l = jumps[3, 0], jumps[3, 1], jumps[3, 2], jumps[3, 3]
    words = np.empty(JUMPS, dtype=np.uint64)
    n = img.size
    # the words after the frame's: where the rejected samples are finished, block by block
    stream = state.copy()
    advance(stream, jumps, (n + 1) // 2)
    halves, s_used = (stream[0], stream[1], np.uint64(0), False), 0
    k = 0
    for start in range(0, n, z.size):
        block_k = k
        stop = min(start + z.size, n)
        count = stop - start
        zb = z[:count]
        groups = count // (2 * JUMPS)
        for g in range(groups):  # four words from one state (see _pcg64), eight samples
            h1, l1 = muladd(hi, lo, a1h, a1l, c1h, c1l)
            h2, l2 = muladd(hi, lo, a2h, a2l, c2h, c2l)
            h3, l3 = muladd(hi, lo, a3h, a3l, c3h, c3l)
            hi, lo = muladd(hi, lo, a4h, a4l, c4h, c4l)
            w1 = output(h1, l1)
            w2 = output(h2, l2)
            w3 = output(h3, l3)
            w4 = output(hi, lo)
            for q in range(2 * JUMPS):  # unrolled: the words stay in registers
                w = w1 if q < 2 else (w2 if q < 4 else (w3 if q < 6 else w4))
                u = np.uint32((w >> np.uint64(32 * (q & 1))) & np.uint64(0xFFFFFFFF))
                mag = np.int32(u >> np.uint32(9))
                signed_layer = u & np.uint32(511)
                zb[2 * JUMPS * g + q] = ftype(mag) * width[signed_layer]
                if mag >= accept[signed_layer]:
                    rejected[k] = start + 2 * JUMPS * g + q
                    first[k] = u
                    k += 1
        tail = count - 2 * JUMPS * groups  # the frame's last samples (an odd count: a half unused)
        for q in range((tail + 1) // 2):
            hi, lo = muladd(hi, lo, a1h, a1l, c1h, c1l)
            words[q] = output(hi, lo)
        for q in range(tail):
            u = np.uint32((words[q >> 1] >> np.uint64(32 * (q & 1))) & np.uint64(0xFFFFFFFF))
            mag = np.int32(u >> np.uint32(9))
            signed_layer = u & np.uint32(511)
            zb[count - tail + q] = ftype(mag) * width[signed_layer]
            if mag >= accept[signed_layer]:
                rejected[k] = stop - tail + q
                first[k] = u
                k += 1
        _noisy_depth_add(img[start:stop], zb, out[start:stop], std_f, near_f, far_f)
        for j in range(block_k, k):  # finish the block's rejected samples while it is in cache
            x, halves, used = _finish_sample(np.int64(first[j]), halves, (a1h, a1l, c1h, c1l))
            s_used += used
            i = rejected[j]
            d = img[i]
            if d > 0.0 and d < far:  # as _noisy_depth_fix redoes a pixel
                out[i] = min(max(d + std * x, near), far)
    state[0] = hi  # the frame's last word
    state[1] = lo
    if k == 0:
        return k
    if s_used <= 2 * (2 * k + 8):
        # random_raw's path draws one batch of 2 k + 8 words after the frame for its k
        # rejections and needed no more than that: the same samples; skip the rest of the batch
        advance(state, jumps, 2 * k + 8)
        return k
    # (rare) it would have run out of that batch and drawn more: redo it as it does
    done = 0
    while done < k:
        extra = np.empty(2 * (k - done) + 8, dtype=np.uint64)
        fill_raw(state, jumps, extra)
        done = _slow_pass(
            first[:k],
            order[:k],
            done,
            scratch[:k],
            extra.view(np.uint32),
            _WIDTH,
            _ACCEPT_I64,
            _FX,
            _R,
        )
    _noisy_depth_fix(img, scratch[:k], out, rejected[:k], std, near, far)
    return k


@numba.njit(cache=True, nogil=True)
def _noisy_ranges(
    ranges: np.ndarray,
    z: np.ndarray,
    u: np.ndarray,
    out: np.ndarray,
    std: float,
    dropout: float,
    rmin: float,
    rmax: float,
) -> int:  # pragma: no cover - compiled
    """Valid beams (finite, < rmax): noise and clip, or rmax when ``u < dropout``."""
    dropped = 0
    for i in range(ranges.size):
        r = ranges[i]
        if r < rmax and r > -np.inf:  # NaN fails both, +-inf fails one
            if u[i] < dropout:
                out[i] = rmax
                dropped += 1
            else:
                out[i] = min(max(r + std * z[i], rmin), rmax)
        else:
            out[i] = r
    return dropped


class DepthNoise(FromSensors, ObservationRandomizer):
    r"""Gaussian range noise on a depth image, N(0, 0.2 m) by default (Liang et al. 2020).

    Liang et al. (2020) add :math:`\mathcal N(0, 0.2)` to the depth images; we read 0.2 as the standard
    deviation in metres. Each valid pixel :math:`d` becomes
    :math:`\mathrm{clip}(d + c\,\sigma z, \mathit{near}, \mathit{far})` with i.i.d.
    :math:`z \sim \mathcal N(0, 1)` per pixel and step. Invalid pixels are returned unchanged:
    NaN or ±inf (REP 118 float depth), ``<= 0`` (no return in 0-coded images) and
    ``>= far_m`` (a max-range reading). Valid pixels closer than ``near_m`` are clipped up to
    it. With an effective std of 0 (``scale=0``) the image passes through untouched.

    Parameters
    ----------
    env : gymnasium.Env
        Env whose observation is (or holds, under ``key``) a float depth image in metres.
    std_m : float
        Noise standard deviation σ, m (>= 0).
    near_m, far_m : float
        The camera's clip range, m (``0 <= near_m < far_m``), e.g. 0.05 and 8.0 for the
        TurtleBot 2 Kinect model in robot-specs.md.
    key : str, optional
        Dict key of the depth image (required for Dict spaces).
    index : int, slice or [start, stop], optional
        Range of the last axis (rarely needed for images).
    scale : float
        Curriculum scale c in [0, 1] multiplying σ and p.
    name : str, optional
        Unique name in the stack; default ``DepthNoise[<key>]``.
    std_per_m, std_per_m2 : float
        Growth σ1 (m per m) and σ2 (1/m) of the noise std with depth and its square (>= 0;
        default 0): σ(d) = σ0 + σ1 d + σ2 d² with σ0 = ``std_m`` (a structured-light or
        stereo camera's error grows with the square of depth).
    dropout : float
        Probability p in [0, 1] that a valid pixel returns nothing, per pixel and step: it
        then reads ``far_m`` (default 0).
    sysid : str, optional
        A ``sim2real sysid sensors`` result with a ``depth`` section: each episode draws σ0,
        σ1, σ2 and p from it (see :meth:`from_sysid`).
    spread : float
        Multiplier on the identified standard deviations (1 = as identified).

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> from randomizers import DepthNoise
    >>> class Cam(gym.Env):
    ...     observation_space = gym.spaces.Box(0.0, 8.0, (4, 4), np.float32)
    ...     action_space = gym.spaces.Discrete(1)
    ...     def reset(self, *, seed=None, options=None):
    ...         super().reset(seed=seed)
    ...         return np.full((4, 4), 2.0, np.float32), {}
    ...     def step(self, action):
    ...         return np.full((4, 4), 2.0, np.float32), 0.0, False, False, {}
    >>> env = DepthNoise(Cam(), std_m=0.2, near_m=0.05, far_m=8.0)
    >>> obs, _ = env.reset(seed=0)
    >>> bool(np.all((obs > 1.0) & (obs < 3.0)) and obs.dtype == np.float32)
    True
    """

    _SECTION = "depth"

    def __init__(
        self,
        env: gym.Env[Any, Any],
        std_m: float = 0.2,
        *,
        near_m: float,
        far_m: float,
        key: str | None = None,
        index: Any = None,
        scale: float = 1.0,
        name: str | None = None,
        std_per_m: float = 0.0,
        std_per_m2: float = 0.0,
        dropout: float = 0.0,
        sysid: str | None = None,
        spread: float = 1.0,
    ) -> None:
        sel = select(env.observation_space, key=key, index=index, wrapper="DepthNoise")
        dist, spread, (std_m, std_per_m, std_per_m2, dropout) = _sensor_model(
            "DepthNoise", (std_m, std_per_m, std_per_m2, dropout), sysid, spread, section="depth"
        )
        near_m = check_nonnegative(near_m, argument="near_m", unit="m")
        far_m = check_number(far_m, argument="far_m")
        if not far_m > near_m:
            raise RandomizerValueError(
                f"DepthNoise: argument 'far_m' must be > near_m={near_m} m, got {far_m!r}; "
                "pass the camera's clip range"
            )
        _check_std_scale(std_m, near_m, far_m, sel.dtype, "DepthNoise", "std_m")
        model = {"std_per_m": std_per_m, "std_per_m2": std_per_m2, "dropout": dropout}
        options: dict[str, Any] = {k: v for k, v in model.items() if v}
        if sysid is not None:
            options |= {"sysid": sysid, "spread": spread}
        self._wrap_selection(
            env,
            sel,
            scale=scale,
            name=name,
            options=options,
            std_m=std_m,
            near_m=near_m,
            far_m=far_m,
        )
        self._keep_model((std_m, std_per_m, std_per_m2, dropout), dist, spread)
        self.near_m = near_m
        self.far_m = far_m
        self._scratch = np.empty(0)  # finished samples of the rejected pixels, in order
        self._rejected = np.empty(0, dtype=np.int64)
        self._first = np.empty(0, dtype=np.uint32)  # the rejected pixels' words
        self._order = np.empty(0, dtype=np.int64)  # 0, 1, 2, ...
        self._z = np.empty(0, dtype=np.float32)  # fast-pass samples of a frame or block (reused)
        self._width = _SIGNED_WIDTH.astype(np.float32)
        self._increment = -1  # the PCG64 stream whose jump table is in self._jumps
        self._jumps = np.empty((0, 4), dtype=np.uint64)

    def observation(self, observation: Any) -> Any:
        """Return ``observation`` with noise on the depth image (a new object)."""
        std = self.scale * self.std_m
        if self.std_per_m > 0.0 or self.std_per_m2 > 0.0 or self.dropout > 0.0:
            return self._sel.put(observation, self._noisy_model(self._sel.get(observation)))
        if std == 0.0:
            return observation
        part = np.ascontiguousarray(self._sel.get(observation))
        if part.dtype not in (np.float32, np.float64):
            part = part.astype(np.float64)
        out = np.empty(part.shape, dtype=self._sel.dtype)
        self._noisy(part.reshape(-1), out.reshape(-1), std)
        return self._sel.put(observation, out)

    def _noisy_model(self, part: np.ndarray) -> np.ndarray:
        """Valid pixels ``d`` become ``clip(d + c sigma(d) z, near, far)``, or ``far`` with
        probability ``c p``; invalid ones are kept (numpy draws, not the compiled path)."""
        d = np.asarray(part, dtype=np.float64)
        c = self.scale
        sigma = c * (self.std_m + (self.std_per_m + self.std_per_m2 * d) * d)
        z = self.rng.standard_normal(d.shape)
        drop = self.rng.random(d.shape) < c * self.dropout
        with np.errstate(invalid="ignore"):
            valid = (d > 0.0) & (d < self.far_m)
            noisy = np.clip(d + sigma * z, self.near_m, self.far_m)
        out = np.where(valid, np.where(drop, self.far_m, noisy), d)
        return out.astype(self._sel.dtype)

    def _noisy(self, img: np.ndarray, out: np.ndarray, std: float) -> None:
        """``out = clip(img + std z, near, far)`` on valid pixels, ``z`` i.i.d. N(0, 1).

        Pixel ``i``'s sample is the ziggurat sample of the ``i``-th 32-bit half of the
        generator's next raw words (as :func:`randomizers._gauss.fill_standard_normal` maps
        words to samples); the few rejected samples are finished with the words after the
        frame's. With numpy's ``PCG64`` (every randomizer's own generator) one compiled kernel
        steps the generator itself (:func:`_noisy_depth_pcg64`); any other bit generator gives
        its words through ``random_raw`` (:meth:`_noisy_raw`). Both give the same frames.
        """
        bits = self.rng.bit_generator
        if not is_pcg64(bits) or sys.byteorder != "little":
            self._noisy_raw(bits, img, out, std)
            return
        self._buffers(img)
        if self._z.size != _DEPTH_BLOCK or self._z.dtype != img.dtype:
            self._z = np.empty(_DEPTH_BLOCK, dtype=img.dtype)
        with bits.lock:
            full, state, increment = pcg64_state(bits)
            if increment != self._increment:  # a new stream (reseeded)
                self._jumps = pcg64_jumps(increment)
                self._increment = increment
            _noisy_depth_pcg64(
                state,
                self._jumps,
                img,
                out,
                self._z,
                self._rejected,
                self._first,
                self._scratch,
                self._order,
                self._width,
                _SIGNED_ACCEPT_I32,
                std,
                self.near_m,
                self.far_m,
            )
            put_pcg64_state(bits, full, state)

    def _buffers(self, img: np.ndarray) -> None:
        """Size the per-pixel buffers for ``img`` and put the width table in its dtype."""
        n = img.size
        if self._scratch.size < n:
            self._scratch = np.empty(n)
            self._rejected = np.empty(n, dtype=np.int64)
            self._first = np.empty(n, dtype=np.uint32)
            self._order = np.arange(n)
        if self._width.dtype != img.dtype:
            self._width = _SIGNED_WIDTH.astype(img.dtype)

    def _noisy_raw(
        self, bits: np.random.BitGenerator, img: np.ndarray, out: np.ndarray, std: float
    ) -> None:
        """:meth:`_noisy` with the words from ``bits.random_raw`` (any bit generator).

        The frame's raw words in one call; the ziggurat fast pass turns word ``i`` into pixel
        ``i``'s sample in a reused buffer, a vectorised pass adds the noise, then the rejected
        samples are finished with further words and their pixels redone.
        """
        self._buffers(img)
        n = img.size
        ftype = img.dtype.type
        if self._z.size < n or self._z.dtype != img.dtype:
            self._z = np.empty(n, dtype=img.dtype)
        words = raw_words(bits, n)
        zf = self._z[:n]
        k = _depth_samples(words, zf, self._rejected, self._width, _ACCEPT_I32)
        _noisy_depth_add(img, zf, out, ftype(std), ftype(self.near_m), ftype(self.far_m))
        if k == 0:
            return
        todo = self._rejected[:k]
        # the rejected pixels' words and samples side by side (no scattered writes)
        first = words[todo]
        z = self._scratch[:k]
        order = self._order[:k]
        done = 0
        while done < k:
            extra = raw_words(bits, 4 * (k - done) + 16)
            done = _slow_pass(first, order, done, z, extra, _WIDTH, _ACCEPT_I64, _FX, _R)
        _noisy_depth_fix(img, z, out, todo, std, self.near_m, self.far_m)

    def episode_record(self) -> dict[str, Any]:
        """Effective std (m) and scale."""
        return self.step_record()

    def step_record(self) -> dict[str, Any]:
        """Effective std (m) and scale."""
        return {"std_m": self.scale * self.std_m, "scale": self.scale}


class LidarNoise(FromSensors, ObservationRandomizer):
    r"""Gaussian range noise plus random beam dropout on a lidar scan.

    Each valid beam :math:`r` (finite and ``< range_max_m``) becomes
    :math:`\mathrm{clip}(r + c\,\sigma(r) z, r_{min}, r_{max})` with
    :math:`\sigma(r) = \sigma_0 + \sigma_1 r + \sigma_2 r^2`, and with probability
    :math:`c\,p` it is dropped: set to ``range_max_m`` (no return). Invalid beams (NaN, inf,
    ``>= range_max_m``) are kept. The default σ = 0.01 m is the LDS-01 noise of the TurtleBot3
    Gazebo model (robot-specs.md).

    Parameters
    ----------
    env : gymnasium.Env
        Env whose observation is (or holds, under ``key``) a Box of ranges in metres.
    std_m : float
        Range noise standard deviation σ, m (>= 0).
    dropout : float
        Probability p in [0, 1] that a valid beam returns nothing, per beam and step.
    key : str, optional
        Dict key of the scan (required for Dict spaces).
    index : int, slice or [start, stop], optional
        Range of the last axis holding the beams.
    range_min_m, range_max_m : float, optional
        Sensor range, m (default: the Box bounds, which must then be finite).
    scale : float
        Curriculum scale c in [0, 1] multiplying σ and p.
    name : str, optional
        Unique name in the stack; default ``LidarNoise[<key>]``.
    std_per_m, std_per_m2 : float
        Growth σ1 (m per m) and σ2 (1/m) of the noise std with range and its square (>= 0;
        default 0: σ = ``std_m``).
    sysid : str, optional
        A ``sim2real sysid sensors`` result: each episode draws σ0, σ1, σ2 and p from it (see
        :meth:`from_sysid`; ``std_m``, ``std_per_m``, ``std_per_m2`` and ``dropout`` are then
        ignored).
    spread : float
        Multiplier on the identified standard deviations (1 = as identified).

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> from randomizers import LidarNoise
    >>> class Scan(gym.Env):
    ...     observation_space = gym.spaces.Box(0.12, 3.5, (36,), np.float32)
    ...     action_space = gym.spaces.Discrete(1)
    ...     def reset(self, *, seed=None, options=None):
    ...         super().reset(seed=seed)
    ...         return np.full(36, 1.0, np.float32), {}
    ...     def step(self, action):
    ...         return np.full(36, 1.0, np.float32), 0.0, False, False, {}
    >>> env = LidarNoise(Scan(), std_m=0.01, dropout=0.5)
    >>> obs, info = env.reset(seed=0)
    >>> 0 < info["randomization"]["LidarNoise"]["dropped"] < 36
    True
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        std_m: float = 0.01,
        dropout: float = 0.0,
        *,
        key: str | None = None,
        index: Any = None,
        range_min_m: float | None = None,
        range_max_m: float | None = None,
        scale: float = 1.0,
        name: str | None = None,
        std_per_m: float = 0.0,
        std_per_m2: float = 0.0,
        sysid: str | None = None,
        spread: float = 1.0,
    ) -> None:
        sel = select(env.observation_space, key=key, index=index, wrapper="LidarNoise")
        dist, spread, (std_m, std_per_m, std_per_m2, dropout) = _sensor_model(
            "LidarNoise", (std_m, std_per_m, std_per_m2, dropout), sysid, spread
        )
        lo = _bound(range_min_m, float(np.min(sel.low)), "range_min_m")
        hi = _bound(range_max_m, float(np.max(sel.high)), "range_max_m")
        if lo < 0 or not hi > lo:
            raise RandomizerValueError(
                f"LidarNoise: the range must satisfy 0 <= range_min_m < range_max_m, got "
                f"[{lo}, {hi}] m; pass the sensor's range_min_m and range_max_m"
            )
        _check_std_scale(std_m, lo, hi, sel.dtype, "LidarNoise", "std_m")
        options: dict[str, Any] = {"range_min_m": lo, "range_max_m": hi, "std_per_m": std_per_m}
        options |= {"std_per_m2": std_per_m2, "sysid": sysid, "spread": spread}
        model = {"std_m": std_m, "dropout": dropout}
        self._wrap_selection(env, sel, scale=scale, name=name, options=options, **model)
        self._keep_model((std_m, std_per_m, std_per_m2, dropout), dist, spread)
        self.range_min_m = lo
        self.range_max_m = hi
        self._dropped = 0

    def observation(self, observation: Any) -> Any:
        """Return ``observation`` with a noisy scan (a new object)."""
        ranges = np.ascontiguousarray(self._sel.get(observation))
        z = self._standard_normal(ranges.size)
        std = self.scale * self.std_m
        if self.std_per_m > 0.0 or self.std_per_m2 > 0.0:  # sigma(r), one per beam
            r = np.where(np.isfinite(ranges), ranges, 0.0).reshape(-1)
            z = z * (self.std_m + (self.std_per_m + self.std_per_m2 * r) * r)
            std = self.scale
        u = self.rng.random(ranges.size)
        out = np.empty(ranges.shape, dtype=self._sel.dtype)
        self._dropped = _noisy_ranges(
            ranges.reshape(-1),
            z,
            u,
            out.reshape(-1),
            std,
            self.scale * self.dropout,
            self.range_min_m,
            self.range_max_m,
        )
        return self._sel.put(observation, out)

    def episode_record(self) -> dict[str, Any]:
        """Effective std, dropout probability, beams dropped in the first scan, scale."""
        return self.step_record()

    def step_record(self) -> dict[str, Any]:
        """Effective std, dropout probability, beams dropped in this scan, scale."""
        return {
            "std_m": self.scale * self.std_m,
            "std_per_m": self.scale * self.std_per_m,
            "std_per_m2": self.scale * self.std_per_m2,
            "dropout": self.scale * self.dropout,
            "dropped": self._dropped,
            "scale": self.scale,
        }


def _sensor_model(
    wrapper: str,
    given: tuple[float, float, float, float],
    sysid: str | None,
    spread: float,
    *,
    section: str | None = None,
) -> tuple[SensorNoiseDistribution | None, float, tuple[float, float, float, float]]:
    """The identified distribution (with ``sysid``; its ``section``), the checked ``spread``
    and the checked noise model ``(std_m, std_per_m, std_per_m2, dropout)``: the identified
    means until the first episode draws its own, else the ``given`` values."""
    spread = check_spread(spread)
    dist = None if sysid is None else load_sensor_noise(sysid, section=section)
    if dist is not None:
        given = dist.std_m[0], dist.std_per_m[0], dist.std_per_m2[0], dist.dropout[0]
    std_m, std_per_m, std_per_m2, dropout = given
    std_m = check_nonnegative(std_m, argument="std_m", unit="m")
    std_per_m = check_nonnegative(std_per_m, argument="std_per_m", unit="m/m")
    std_per_m2 = check_nonnegative(std_per_m2, argument="std_per_m2", unit="1/m")
    dropout = check_nonnegative(dropout, argument="dropout")
    if dropout > 1.0:
        raise RandomizerValueError(
            f"{wrapper}: argument 'dropout' is a probability and must be in [0, 1], got {dropout!r}"
        )
    return dist, spread, (std_m, std_per_m, std_per_m2, dropout)


def _bound(value: float | None, from_space: float, argument: str) -> float:
    if value is None:
        if not np.isfinite(from_space):
            raise RandomizerValueError(
                f"LidarNoise: argument '{argument}' is required because the scan's Box bound is "
                f"{from_space}; pass the sensor's range in metres"
            )
        return from_space
    return check_number(value, argument=argument)


#: A noise std beyond this many times the observation's range (finite bounds) is refused.
MAX_STD_PER_RANGE = 1000.0


def _check_std_scale(
    std: float | np.ndarray, low: Any, high: Any, dtype: Any, wrapper: str, argument: str
) -> None:
    """Refuse a std orders of magnitude beyond the observation's range (or its dtype)."""
    stds = np.atleast_1d(
        np.broadcast_to(np.asarray(std, dtype=np.float64), np.shape(np.asarray(high))[-1:])
    )
    lo = np.asarray(low, dtype=np.float64)
    hi = np.asarray(high, dtype=np.float64)
    span = (hi - lo).reshape(-1, stds.size if stds.size else 1).max(axis=0)
    limit = np.where(np.isfinite(span), MAX_STD_PER_RANGE * span, np.inf)
    kind = np.dtype(dtype)
    if kind.kind == "f":  # noise must stay representable after the cast
        limit = np.minimum(limit, float(np.finfo(kind).max) * 1e-6)
    bad = np.flatnonzero(stds > limit)
    if bad.size:
        i = int(bad[0])
        raise RandomizerValueError(
            f"{wrapper}: argument '{argument}' = {float(stds[i]):.3g} is more than "
            f"{MAX_STD_PER_RANGE:g}x the observation's range ({float(span[i]):.3g}, element "
            f"{i}) or too large for {kind.name}; give a std on the scale of the observation"
        )


def _check_std(std: Any, width: int, *, argument: str) -> float | np.ndarray:
    """A scalar std >= 0, or one per element of the selected last axis."""
    if isinstance(std, Sequence | np.ndarray) and not isinstance(std, str):
        values = [check_nonnegative(s, argument=argument) for s in std]
        if len(values) != width:
            raise RandomizerValueError(
                f"argument '{argument}' has {len(values)} entries but the selected part has "
                f"{width} elements on its last axis; give one std per element or a single float"
            )
        return np.asarray(values, dtype=np.float64)
    return check_nonnegative(std, argument=argument)
