"""SARL's value network with a one-step look-ahead (``policy: sarl-lookahead``): the predicted
observation against the real Race-v0 step, its invariants, the smoke config trained and
evaluated in under 60 s (its bad-input sentences and doctest: test_train_sarl.py)."""

from __future__ import annotations

import copy
import math
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.training.config import load_config
from sim2real.training.evaluation import check_spaces, load_policy
from sim2real.training.train import train

pytestmark = pytest.mark.train
torch = pytest.importorskip("torch")

from sim2real.training._lookahead import (  # noqa: E402
    LookaheadQNetwork,
    RaceLookahead,
    race_lookahead,
)

ROOT = Path(__file__).resolve().parents[3]
GRID = {"v_mps": [0.0, 0.11, 0.22], "w_radps": [-1.5, -0.6, -0.2, 0.0, 0.2, 0.6, 1.5]}
BEAMS, OWN = 36, 7


def _race(opponents: int) -> gym.Env:  # type: ignore[type-arg]
    """The curve race with the goal line's centre as the goal (a fixed point)."""
    return gym.make(
        "sim2real/Race-v0", track="curve", num_opponents=opponents, control_dt=0.25
    ).unwrapped


def _steady(env: gym.Env, seed: int, command: tuple[float, float], steps: int) -> np.ndarray:  # type: ignore[type-arg]
    obs, _ = env.reset(seed=seed)
    for _ in range(steps):
        obs, *_ = env.step(np.array(command, np.float32))
    return np.asarray(obs)


@pytest.mark.parametrize(
    ("seed", "command"), [(3, (0.22, 0.0)), (5, (0.22, 0.2)), (7, (0.11, -0.6))]
)
def test_prediction_matches_the_race_step_at_steady_speed(
    seed: int, command: tuple[float, float]
) -> None:
    env = _race(4)
    model = race_lookahead(env, **GRID)
    obs = _steady(env, seed, command, 6)  # the drive has reached the command
    k = [(v, w) for v in GRID["v_mps"] for w in GRID["w_radps"]].index(command)
    pred = model.predict(torch.as_tensor(obs)[None])[0, k].numpy()
    nxt, *_ = copy.deepcopy(env).step(np.array(command, np.float32))
    own, real = pred[BEAMS : BEAMS + OWN], nxt[BEAMS : BEAMS + OWN]
    np.testing.assert_allclose(own[:2], real[:2], atol=0.004)  # x, y m
    assert abs(own[2] - real[2]) < 0.03  # yaw rad (the drive lags the turn rate slightly)
    assert abs(own[5] - real[5]) < 0.01 and abs(own[6] - real[6]) < 0.03  # goal m, rad
    # movers: each predicted one lies within 3 cm of an observed one (order may change)
    rows_p = pred[BEAMS + OWN :].reshape(5, 4)
    rows_r = nxt[BEAMS + OWN :].reshape(5, 4)
    live_p = rows_p[np.abs(rows_p).sum(1) > 0]
    live_r = rows_r[np.abs(rows_r).sum(1) > 0]
    assert len(live_p) == len(obs[BEAMS + OWN :].reshape(5, 4).any(1).nonzero()[0]) >= 1
    gaps = np.hypot(*(live_p[:, None, :2] - live_r[None, :, :2]).transpose(2, 0, 1)).min(1)
    assert gaps.max() < 0.03, gaps
    # the scan ahead moves with the opponent in front of the robot; the rest is static


def _point_scan(beam: int, range_m: float) -> np.ndarray:
    obs = np.zeros(BEAMS + OWN + 20)
    obs[:BEAMS] = 3.5
    obs[beam] = range_m
    return obs


def test_a_return_moves_as_a_point() -> None:
    model = race_lookahead(_race(0), **GRID)
    obs = _point_scan(3, 1.0)  # a return 1 m away at 30 degrees
    pred = model.predict(torch.as_tensor(obs)[None])[0].numpy()
    ahead = pred[[(v, w) for v in GRID["v_mps"] for w in GRID["w_radps"]].index((0.22, 0.0))]
    expected = math.hypot(math.cos(math.pi / 6) - 0.055, 0.5)  # 5.5 cm further on
    assert ahead[3] == pytest.approx(expected, abs=1e-5)
    assert np.all(np.delete(ahead[:BEAMS], 3) == 3.5)
    left = pred[[(v, w) for v in GRID["v_mps"] for w in GRID["w_radps"]].index((0.0, 0.6))]
    assert int(np.argmin(left[:BEAMS])) == 2  # turning left by 8.6 degrees: it moves right


def test_predicted_scan_turns_with_the_robot() -> None:
    env = _race(0)  # no movers: every return is a wall or an island
    model = race_lookahead(env, **GRID)
    obs = _steady(env, 1, (0.0, 0.6), 6)
    k = [(v, w) for v in GRID["v_mps"] for w in GRID["w_radps"]].index((0.0, 0.6))
    pred = model.predict(torch.as_tensor(obs)[None])[0, k].numpy()[:BEAMS]
    nxt, *_ = copy.deepcopy(env).step(np.array([0.0, 0.6], np.float32))
    err = np.abs(pred - nxt[:BEAMS]).mean()
    assert err < 0.5 * np.abs(obs[:BEAMS] - nxt[:BEAMS]).mean()  # better than no prediction
    assert err < np.abs(np.roll(obs[:BEAMS], -1) - nxt[:BEAMS]).mean()  # turned the wrong way


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**16), movers=st.integers(0, 5))
def test_standing_still_among_standing_movers_changes_nothing(seed: int, movers: int) -> None:
    """Command (0, 0) and movers at rest in the world: the same scene, velocities zero."""
    rng = np.random.default_rng(seed)
    model = RaceLookahead(
        v_mps=(0.0, 0.22),
        w_radps=(0.0, 0.0),
        control_dt_s=0.25,
        beam_angles_rad=tuple(2 * math.pi * np.arange(BEAMS) / BEAMS),
        range_min_m=0.12,
        range_max_m=3.5,
    )
    v = rng.uniform(0.0, 0.22)
    own = [rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-3, 3), v, rng.uniform(-1, 1)]
    own += [rng.uniform(0.2, 1.0), rng.uniform(-3, 3)]
    rows = np.zeros((5, 4))
    rows[:movers, :2] = rng.uniform(0.3, 2.0, (movers, 2)) * rng.choice([-1, 1], (movers, 2))
    rows[:movers, 2] = -v  # at rest in the world: relative velocity minus the robot's
    obs = np.concatenate([rng.uniform(0.12, 3.5, BEAMS), own, rows.reshape(-1)])
    pred = model.predict(torch.as_tensor(obs, dtype=torch.float64)[None])[0].numpy()
    still = pred[0]
    np.testing.assert_allclose(still[:BEAMS], obs[:BEAMS], atol=1e-9)
    np.testing.assert_allclose(still[BEAMS : BEAMS + 3], obs[BEAMS : BEAMS + 3], atol=1e-9)
    np.testing.assert_allclose(still[BEAMS + 3 : BEAMS + 5], 0.0)
    np.testing.assert_allclose(still[BEAMS + 5 : BEAMS + 7], obs[BEAMS + 5 : BEAMS + 7], atol=1e-9)
    moved = still[BEAMS + OWN :].reshape(5, 4)
    np.testing.assert_allclose(moved[:, :2], rows[:, :2], atol=1e-9)
    np.testing.assert_allclose(moved[:, 2:], 0.0, atol=1e-9)  # empty slots stay zero too
    # driving straight at 0.22 m/s: everything ahead is 5.5 cm nearer, the movers come at -0.22
    ahead = pred[1][BEAMS + OWN :].reshape(5, 4)
    np.testing.assert_allclose(ahead[:movers, 0], rows[:movers, 0] - 0.055, atol=1e-9)
    np.testing.assert_allclose(ahead[:movers, 2], -0.22, atol=1e-9)
    assert not ahead[movers:].any()


def _smoke_doc(tmp_path: Path, **change: object) -> Path:
    doc = yaml.safe_load((ROOT / "examples" / "race_sarl_lookahead_smoke.yaml").read_text("utf-8"))
    doc.update(change, out=str(tmp_path / "run"))
    path = tmp_path / "smoke.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def test_race_smoke_trains_and_evaluates_under_60_s(tmp_path: Path) -> None:
    start = time.perf_counter()
    result = train(load_config(_smoke_doc(tmp_path)))
    elapsed_s = time.perf_counter() - start
    assert elapsed_s < 60.0, f"{elapsed_s:.1f} s"
    assert result.timesteps >= 400 and result.evaluation["episodes"] == 2
    policy = load_policy(result.model_path)
    q_net = policy.model.policy.q_net
    assert isinstance(q_net, LookaheadQNetwork) and q_net.model.control_dt_s == 0.25
    env = policy.wrap(gym.make("sim2real/Race-v0", track="open", num_opponents=3, control_dt=0.25))
    check_spaces(policy, env, "Race-v0")
    obs, _ = env.reset(seed=3)
    batch = torch.as_tensor(obs)[None]
    with torch.no_grad():  # Q(s, a) is the value head on each action's predicted observation
        q = q_net(batch)[0]
        nxt = q_net.model.predict(batch)[0]
        v = q_net.q_net(q_net.features_extractor(nxt))[:, 0]
    np.testing.assert_allclose(q.numpy(), v.numpy(), rtol=1e-5, atol=1e-6)
    assert int(policy.controller().act(obs)) == int(q.argmax())


def test_full_and_smoke_configs_share_grid_step_and_widths() -> None:
    full, smoke = (
        yaml.safe_load((ROOT / "examples" / name).read_text("utf-8"))
        for name in ("race_sarl_lookahead.yaml", "race_sarl_lookahead_smoke.yaml")
    )
    assert smoke["discrete_actions"] == full["discrete_actions"] == GRID
    assert smoke["env"]["kwargs"]["control_dt"] == full["env"]["kwargs"]["control_dt"]
    widths = [d["hyperparameters"]["policy_kwargs"] for d in (full, smoke)]
    assert widths[0] == widths[1]
