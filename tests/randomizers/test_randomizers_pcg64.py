"""numpy's PCG64 stepped in compiled code (issue 16): the words of ``random_raw`` bit for bit, and
DepthNoise's kernel on it gives the frames of its ``random_raw`` path."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

from randomizers import DepthNoise
from randomizers._pcg64 import (
    MULTIPLIER,
    advance,
    fill_raw,
    pcg64_jumps,
    pcg64_state,
    put_pcg64_state,
)

NEAR, FAR, STD = 0.05, 8.0, 0.2


@pytest.mark.parametrize("seed", [0, 1, 2**63 + 5])
@pytest.mark.parametrize("count", [0, 1, 3, 4, 5, 8, 1001])
def test_fill_raw_gives_the_words_of_random_raw(seed: int, count: int) -> None:
    bits = np.random.PCG64(seed)
    ours = copy.deepcopy(bits)
    full, state, increment = pcg64_state(ours)
    jumps = pcg64_jumps(increment)
    for _ in range(3):  # consecutive calls continue the stream
        got = np.empty(count, dtype=np.uint64)
        fill_raw(state, jumps, got)
        np.testing.assert_array_equal(got, bits.random_raw(count))
    put_pcg64_state(ours, full, state)
    assert ours.state == bits.state
    assert ours.random_raw() == bits.random_raw()


def test_jump_table_takes_the_state_one_to_four_steps_ahead() -> None:
    bits = np.random.PCG64(7)
    s0 = int(bits.state["state"]["state"])
    jumps = pcg64_jumps(int(bits.state["state"]["inc"]))
    for j in range(1, 5):
        ahead = copy.deepcopy(bits).advance(j)
        a = (int(jumps[j - 1, 0]) << 64) | int(jumps[j - 1, 1])
        c = (int(jumps[j - 1, 2]) << 64) | int(jumps[j - 1, 3])
        assert (a * s0 + c) % 2**128 == ahead.state["state"]["state"]
        assert a == pow(MULTIPLIER, j, 2**128)


class _Cam(gym.Env[np.ndarray, int]):
    action_space = gym.spaces.Discrete(1)

    def __init__(self, shape: tuple[int, ...], dtype: type[np.floating]) -> None:  # type: ignore[type-arg]
        self.observation_space = gym.spaces.Box(0.0, FAR, shape, dtype)


def _image(shape: tuple[int, ...], dtype: type[np.floating], seed: int) -> np.ndarray:  # type: ignore[type-arg]
    img = np.random.default_rng(seed).uniform(-0.5, 9.0, shape).astype(dtype)
    img.reshape(-1)[5::13] = np.nan
    img.reshape(-1)[2::17] = np.inf
    img.reshape(-1)[0] = 2.0  # at least one valid pixel
    return img


@pytest.mark.parametrize(
    ("shape", "dtype"),
    [
        ((1,), np.float32),  # one word, half of it unused
        ((7, 9), np.float32),  # odd pixel count below one iteration's eight samples
        ((5, 3), np.float64),
        ((33, 65), np.float64),  # odd count beyond one block
        ((64, 64), np.float32),
        ((480, 640), np.float32),
    ],
)
def test_depth_kernel_equals_the_random_raw_path(
    shape: tuple[int, ...],
    dtype: type[np.floating],  # type: ignore[type-arg]
) -> None:
    img = _image(shape, dtype, seed=3)
    fused = DepthNoise(_Cam(shape, dtype), STD, near_m=NEAR, far_m=FAR)
    raw = DepthNoise(_Cam(shape, dtype), STD, near_m=NEAR, far_m=FAR)
    fused.rng = np.random.default_rng(11)  # numpy's default bit generator is PCG64
    raw.rng = np.random.default_rng(11)
    # a buffered 32-bit half in the generator must survive the state round trip
    state = fused.rng.bit_generator.state
    state["has_uint32"], state["uinteger"] = 1, 12345
    fused.rng.bit_generator.state = state
    raw.rng.bit_generator.state = state
    flat = img.reshape(-1)
    for _ in range(3):
        got = fused.observation(img)
        want = np.empty_like(flat)
        raw._noisy_raw(raw.rng.bit_generator, flat, want, STD)
        np.testing.assert_array_equal(got, want.reshape(shape))  # NaN == NaN here
        assert fused.rng.bit_generator.state == raw.rng.bit_generator.state
    assert fused.rng.bit_generator.state["uinteger"] == 12345
    valid = (img > 0) & (img < FAR)
    assert np.mean(got[valid] != img[valid]) > 0.99


def test_other_bit_generators_take_the_random_raw_path() -> None:
    img = _image((48, 64), np.float32, seed=4)
    env = DepthNoise(_Cam((48, 64), np.float32), STD, near_m=NEAR, far_m=FAR)
    env.rng = np.random.Generator(np.random.SFC64(9))
    first = env.observation(img)
    env.rng = np.random.Generator(np.random.SFC64(9))
    again = env.observation(img)
    np.testing.assert_array_equal(first, again)
    inside = (img > 1.0) & (img < 7.0)
    d = first[inside].astype(np.float64) - img[inside]
    assert abs(d.mean()) < 0.02 and abs(d.std() - STD) < 0.02


@pytest.mark.parametrize("steps", [0, 1, 2, 5, 153_600, 2**40 + 3])
def test_advance_equals_numpy_advance(steps: int) -> None:
    bits = np.random.PCG64(21)
    full, state, increment = pcg64_state(bits)
    advance(state, pcg64_jumps(increment), steps)
    put_pcg64_state(bits, full, state)
    assert bits.state == np.random.PCG64(21).advance(steps).state
