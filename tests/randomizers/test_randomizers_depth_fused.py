"""DepthNoise's compiled passes (issue 16) gives the ziggurat samples of its generator's
words (to float32 rounding): pixel ``i`` gets the sample of word ``i``, rejected words finished with the
words drawn after the frame's, invalid pixels untouched."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

from randomizers import DepthNoise
from randomizers._gauss import _ACCEPT_I64, _FX, _R, _SIGNED_WIDTH, _WIDTH, _fast_pass, _slow_pass

NEAR, FAR, STD = 0.05, 8.0, 0.2


class _Cam(gym.Env[np.ndarray, int]):
    observation_space = gym.spaces.Box(0.0, FAR, (48, 64), np.float32)
    action_space = gym.spaces.Discrete(1)

    def reset(
        self, *, seed: int | None = None, options: dict[str, object] | None = None
    ) -> tuple[np.ndarray, dict[str, object]]:
        super().reset(seed=seed)
        return np.full((48, 64), 2.0, np.float32), {}


def _reference(bits: np.random.BitGenerator, img: np.ndarray, std: float) -> np.ndarray:
    """The same samples through the separate fast and slow passes of randomizers._gauss."""
    flat = img.reshape(-1)
    n = flat.size
    words = bits.random_raw((n + 1) // 2).view(np.uint32)
    z = np.empty(n)
    rejected = np.empty(n, dtype=np.int64)
    k = _fast_pass(words, z, rejected, _SIGNED_WIDTH, _ACCEPT_I64)
    done = 0
    while done < k:
        extra = bits.random_raw(2 * (k - done) + 8).view(np.uint32)
        done = _slow_pass(words, rejected[:k], done, z, extra, _WIDTH, _ACCEPT_I64, _FX, _R)
    valid = (flat > 0.0) & (flat < FAR)
    noisy = np.minimum(np.maximum(flat.astype(np.float64) + std * z, NEAR), FAR)
    return np.where(valid, noisy, flat).astype(np.float32).reshape(img.shape)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fused_kernel_equals_the_two_pass_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    img = rng.uniform(0.01, 9.0, (48, 64)).astype(np.float32)
    img[::7, ::5] = np.nan
    img[3, :4] = [np.inf, -np.inf, 0.0, -1.0]
    env = DepthNoise(_Cam(), STD, near_m=NEAR, far_m=FAR)
    env.reset(seed=seed)
    for _ in range(3):
        bits = copy.deepcopy(env.rng.bit_generator)
        got = env.observation(img)
        want = _reference(bits, img, STD)
        # float32 frames are computed in float32: equal up to a few float32 roundings
        np.testing.assert_allclose(got, want, rtol=0.0, atol=4e-6)
        assert np.mean(got == want) > 0.9
        assert got.dtype == np.float32
        invalid = ~((img > 0) & (img < FAR))
        np.testing.assert_array_equal(got[invalid], img[invalid])  # NaN == NaN here
        assert np.all((got[~invalid] >= NEAR) & (got[~invalid] <= FAR))


def test_noise_statistics_on_a_large_frame() -> None:
    img = np.full((480, 640), 4.0, np.float32)
    env = DepthNoise(_Cam(), STD, near_m=NEAR, far_m=FAR)
    env.reset(seed=5)
    d = env.observation(img).astype(np.float64) - 4.0
    assert abs(d.mean()) < 0.002 and abs(d.std() - STD) < 0.002
    # tails exist (slow path taken) and are not clipped away
    assert np.mean(np.abs(d) > 3 * STD) == pytest.approx(0.0027, abs=0.0008)


@pytest.mark.parametrize("bit_generator", ["MT19937", "Philox", "SFC64", "PCG64DXSM"])
def test_noise_statistics_with_every_numpy_bit_generator(bit_generator: str) -> None:
    """A user's own Generator works too. MT19937's raw values hold 32 bits: read as two 32-bit
    halves (as before), every other sample came from a zero word (std 0.14 instead of 0.2)."""
    img = np.full((480, 640), 4.0, np.float32)
    env = DepthNoise(_Cam(), STD, near_m=NEAR, far_m=FAR)
    env.reset(seed=5)
    env.rng = np.random.Generator(getattr(np.random, bit_generator)(11))
    d = env.observation(img).astype(np.float64) - 4.0
    assert abs(d.mean()) < 0.002 and abs(d.std() - STD) < 0.002
    assert np.mean(np.abs(d) > 3 * STD) == pytest.approx(0.0027, abs=0.0008)
    # reproducible: the same generator state gives the same frame
    env.rng = np.random.Generator(getattr(np.random, bit_generator)(11))
    assert np.array_equal(env.observation(img).astype(np.float64) - 4.0, d)
