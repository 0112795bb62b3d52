r"""Native vector envs: N reduced-dynamics navigation envs stepped as arrays in one process.

``gym.make_vec("sim2real/RandomMap-v0", num_envs=N, vectorization_mode="vector_entry_point")``
builds a :class:`RandomMapVectorEnv` (``"sim2real/CrowdNav-v0"``: :class:`CrowdNavVectorEnv`).
It steps the N robots (drive model, command history, pose), their lidars (each env's
obstacles held as padded arrays) and their goals in compiled loops
(:mod:`sim2real.envs._vecnav`) instead of N Python ``step`` calls. The numbers are the single
env's: env *i* of the vector env and the single env reset with the same seed and given the
same actions produce the same observations, rewards, ends and infos (tested against
gymnasium's ``SyncVectorEnv``). CrowdNav's eq. (1) pedestrians walk and its depth images are
rendered for all sub-envs in compiled loops too (the single env's kernels,
:func:`sim2real.envs.pedestrians.walk` and :func:`sim2real.envs.depth.render_frame`); ORCA
crowds step per sub-env by the sub-env's own crowd object.

Gymnasium conventions
---------------------
- ``reset(seed=s)`` seeds sub-env *i* with ``s + i`` (a list gives one seed per sub-env);
  ``options`` go to every sub-env, ``options={"reset_mask": mask}`` resets only some.
- Autoreset: ``metadata["autoreset_mode"]`` is ``AutoresetMode.NEXT_STEP`` (gymnasium's
  default): the step after a sub-env's episode ended resets it (its action is ignored, its
  reward is 0 and it is neither terminated nor truncated) and returns its first observation.
- Infos are gymnasium's vector infos: one array per key and a boolean mask ``"_key"`` of the
  sub-envs that have it (``info["outcome"]``, ``info["metrics"]`` at episode ends, ...).
- Maps are drawn per sub-env by the single env's own code from the sub-env's ``np_random``
  (only the step runs as arrays); ``envs.envs[i]`` is sub-env *i* (for its map, ``layout``).
- Drive parameters: :meth:`NavVectorEnv.set_drive_params` (one per sub-env, or one for all)
  take effect at the next step and persist across resets, as in the single env.

Examples
--------
>>> import gymnasium as gym
>>> import numpy as np
>>> import sim2real.envs
>>> envs = gym.make_vec("sim2real/RandomMap-v0", num_envs=4,
...                     vectorization_mode="vector_entry_point", preset="TEST1")
>>> obs, info = envs.reset(seed=0)
>>> obs.shape, obs.dtype
((4, 40), dtype('float32'))
>>> actions = np.tile(np.array([0.2, 0.0], np.float32), (4, 1))
>>> obs, rewards, terminated, truncated, info = envs.step(actions)
>>> rewards.shape, terminated.dtype
((4,), dtype('bool'))
>>> envs.close()
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import astuple
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from robots import _jit
from robots.params import DriveParams
from robots.reduced import _HISTORY_ROWS, ReducedDrive
from sim2real.envs._nav import NavEnvBase
from sim2real.envs._robot import ReducedBackend
from sim2real.envs._vecnav import (
    Crowds,
    Drives,
    Episodes,
    Readings,
    crowd_clock,
    finish_crowd_nav,
    finish_random_map,
    history_rows,
    move_robots,
    render_depths,
    sense,
    walk_crowds,
)
from sim2real.envs.crowd_nav import CrowdNavEnv
from sim2real.envs.depth import _packed_boxes
from sim2real.envs.geometry import FloatArray, Scene2D
from sim2real.envs.metrics import episode_metrics
from sim2real.envs.pedestrians import (
    _COS_OFFSETS,
    _GOAL_REACHED_M,
    _HEADING_OFFSETS,
    _OFFSET_PENALTY,
    Crowd,
)
from sim2real.envs.random_map import RandomMapEnv
from sim2real.errors import Sim2RealValueError

__all__ = ["CrowdNavVectorEnv", "NavVectorEnv", "RandomMapVectorEnv"]


def _check_num_envs(num_envs: Any) -> int:
    if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
        raise Sim2RealValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
    return int(num_envs)


def _with_room(a: np.ndarray, slots: int) -> np.ndarray:
    """The per-sub-env array ``a`` (sub-envs, slots, ...) with ``slots`` slots on its second
    axis: its contents first, zeros after."""
    grown = np.zeros((a.shape[0], slots, *a.shape[2:]), dtype=a.dtype)
    grown[:, : a.shape[1]] = a
    return grown


def _info_dtype(value: Any) -> Any:
    """The array dtype gymnasium's vector infos use for ``value`` (``VectorEnv._add_info``)."""
    if type(value) in (int, float, bool) or isinstance(value, np.number):
        return type(value)
    return object


class NavVectorEnv(VectorEnv):  # type: ignore[type-arg]
    """Shared machinery of the native vector navigation envs (reduced dynamics or plant).

    Sub-env objects (the single envs) draw the worlds at reset; the vector env copies each
    new world and robot into arrays and steps all robots in compiled loops.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012
        "render_modes": [],
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(self, envs: Sequence[NavEnvBase]) -> None:
        super().__init__()
        # The kernels of _vecnav call robots' drive kernels, which robots compiles on first use
        # (robots._jit): bind them to their numba dispatchers before numba types ours, or a
        # process whose first kernel call is a vector env's step fails to compile.
        _jit.compile_all()
        self.envs = list(envs)
        first = self.envs[0]
        if first.dynamics not in ("reduced", "plant"):
            raise Sim2RealValueError(
                f"the native vector env steps the reduced drive model or the plant, got "
                f"dynamics={first.dynamics!r}; use dynamics='reduced' or 'plant', or "
                "vectorization_mode='sync' for pybullet"
            )
        if math.isfinite(first.goal_speed_mps):
            raise Sim2RealValueError(
                f"the native vector env ends an episode at the goal by distance alone, got "
                f"goal_speed_mps={first.goal_speed_mps!r}; leave goal_speed_mps out, or use "
                "vectorization_mode='sync' (or vec_env='dummy') to require a stop at the goal"
            )
        #: ``dynamics="plant"``: each sub-env's plant steps its robot (one call per sub-env).
        self._plant = first.dynamics == "plant"
        self.num_envs = len(self.envs)
        self.autoreset_mode = AutoresetMode.NEXT_STEP
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        #: Control period, s (as the single env's ``control_dt``).
        self.control_dt = first.control_dt
        self.max_episode_steps = first.max_episode_steps
        n = self.num_envs
        # the sub-step split of ReducedBackend.step and ReducedDrive.step (same arithmetic)
        drive = first._backend  # with the plant, its arrays stay unused
        if not isinstance(drive, ReducedBackend):
            drive = ReducedBackend(first.robot_spec, first.robot_spec.drive)
        n_sub = max(1, math.ceil(self.control_dt / drive._substep_s - 1e-9))
        sub_s = self.control_dt / n_sub
        n_inner = max(1, round(sub_s / drive._drive.dt_s))
        lid = first.robot_spec.lidar
        self._lidar_xy = np.array([lid.xyz_m[0], lid.xyz_m[1]], dtype=np.float64)
        self._range_min = float(lid.range_min_m)
        self._range_max = float(lid.range_max_m)
        self._radius = float(first.robot_radius_m)
        self._act_low = np.asarray(self.single_action_space.low, dtype=np.float64)  # type: ignore[attr-defined]
        self._act_high = np.asarray(self.single_action_space.high, dtype=np.float64)  # type: ignore[attr-defined]
        # robot state
        self._pose = np.zeros((n, 3))
        self._drives = Drives(
            state=np.zeros((n, 6)),
            hist=np.zeros((n, _HISTORY_ROWS, 3)),
            n_hist=np.zeros(n, dtype=np.int64),
            time_s=np.zeros(n),
            delay_s=np.zeros(n),
            timeout_s=np.zeros(n),
            packed=np.zeros((n, drive._drive._packed.shape[0])),
            n_sub=n_sub,
            sub_s=sub_s,
            n_inner=n_inner,
            inner_s=sub_s / n_inner,
        )
        # world
        self._cxy = np.zeros((n, 0, 2))
        self._cr = np.zeros((n, 0))
        self._nc = np.zeros(n, dtype=np.int64)
        self._sa = np.zeros((n, 0, 2))
        self._sb = np.zeros((n, 0, 2))
        self._ns = np.zeros(n, dtype=np.int64)
        self._goal = np.zeros((n, 2))
        # the reward constants as the kernels read them: the fields in order, tuples flattened
        reward = first.reward_config  # type: ignore[attr-defined]
        self._consts = np.hstack(astuple(reward)).astype(np.float64)
        # episode
        self._episodes = Episodes(
            steps=np.zeros(n, dtype=np.int64),
            vw_hist=np.zeros((n, self.max_episode_steps + 1, 2)),
            prev_goal=np.zeros(n),
            max_steps=self.max_episode_steps,
            goal_tol=float(first.goal_tolerance_m),
        )
        self._path = np.zeros(n)
        self._autoreset = np.zeros(n, dtype=np.bool_)
        self._was_reset = np.zeros(n, dtype=np.bool_)
        self._extra: dict[str, np.ndarray] = {}
        for i in range(n):
            self._load_drive(i)
        self._sensed = Readings(
            ranges=np.zeros((n, 0)), goal_polar=np.zeros((n, 2)), clearance=np.zeros(n)
        )

    # ------------------------------------------------------------------ drive protocol
    def get_drive_params(self) -> tuple[DriveParams, ...]:
        """The drive parameters of every sub-env's robot."""
        return tuple(env.get_drive_params() for env in self.envs)

    def set_drive_params(self, params: DriveParams | Sequence[DriveParams | None]) -> None:
        """Use ``params`` from the next step on: one ``DriveParams`` for all sub-envs, or one
        per sub-env (``None`` keeps that sub-env's)."""
        if isinstance(params, DriveParams):
            seq: list[DriveParams | None] = [params] * self.num_envs
        else:
            seq = list(params)
            if len(seq) != self.num_envs:
                raise Sim2RealValueError(
                    f"set_drive_params needs one DriveParams or a sequence of {self.num_envs} "
                    f"(one per sub-env), got {len(seq)}"
                )
        for i, p in enumerate(seq):
            if p is not None:
                self.envs[i].set_drive_params(p)
                self._load_drive(i)

    def _load_drive(self, i: int) -> None:
        """Copy sub-env ``i``'s drive parameters into the arrays."""
        if self._plant:
            return
        drive, arrays = self._drive(i), self._drives
        arrays.packed[i] = drive._packed
        arrays.delay_s[i] = drive.params.delay_s
        arrays.timeout_s[i] = drive.params.cmd_timeout_s
        self._room_for_history(history_rows(float(arrays.delay_s.max()), arrays.sub_s))

    def _drive(self, i: int) -> ReducedDrive:
        backend = self.envs[i]._backend
        assert isinstance(backend, ReducedBackend)
        return backend._drive

    # ------------------------------------------------------------------ world arrays
    def _load_scene(self, i: int, scene: Scene2D) -> None:
        """Copy sub-env ``i``'s obstacles into the padded arrays (grown when needed)."""
        nc, ns = scene.circles_r.shape[0], scene.seg_a.shape[0]
        if nc > self._cr.shape[1]:
            cap = max(nc, 2 * self._cr.shape[1])
            self._cxy, self._cr = _with_room(self._cxy, cap), _with_room(self._cr, cap)
        if ns > self._sa.shape[1]:
            cap = max(ns, 2 * self._sa.shape[1])
            self._sa, self._sb = _with_room(self._sa, cap), _with_room(self._sb, cap)
        self._cxy[i, :nc] = scene.circles_xy
        self._cr[i, :nc] = scene.circles_r
        self._nc[i] = nc
        self._sa[i, :ns] = scene.seg_a
        self._sb[i, :ns] = scene.seg_b
        self._ns[i] = ns

    def _load_episode(self, i: int) -> None:
        """Copy sub-env ``i``'s freshly reset episode (robot, world, goal) into the arrays."""
        env = self.envs[i]
        backend = env._backend
        self._pose[i] = backend.pose
        if self._plant:
            self._drives.state[i, :2] = backend.velocity
        else:
            self._load_reduced(i)
        self._load_scene(i, env._dynamic_scene())
        self._goal[i] = env._goal
        self._episodes.prev_goal[i] = env._prev_goal_dist
        self._episodes.steps[i] = 0
        self._was_reset[i] = True
        self._path[i] = 0.0
        self._episodes.vw_hist[i, 0] = 0.0
        self._autoreset[i] = False
        for key, value in env._extra_info().items():
            column = self._extra.get(key)
            if column is None:
                column = np.zeros(self.num_envs, dtype=_info_dtype(value))
                if column.dtype == object:
                    column[:] = None
                self._extra[key] = column
            column[i] = value
        self._load_more(i)

    def _load_reduced(self, i: int) -> None:
        """Copy sub-env ``i``'s freshly reset drive model (state, history, clock)."""
        drive = self._drive(i)
        n = drive._n
        self._room_for_history(n)
        arrays = self._drives
        arrays.state[i] = drive._state
        arrays.hist[i, :n] = drive._hist[:n]
        arrays.n_hist[i] = n
        arrays.time_s[i] = drive.time_s
        self._load_drive(i)

    def _room_for_history(self, rows: int) -> None:
        """Grow every sub-env's command history to at least ``rows`` rows."""
        hist = self._drives.hist
        if rows > hist.shape[1]:
            self._drives = self._drives._replace(hist=_with_room(hist, rows))

    def _move(self, active: np.ndarray, cmd: FloatArray) -> None:
        """One control step of the active sub-envs' robots (pose, velocity, path length)."""
        if not self._plant:
            move_robots(active, cmd, self._drives, self._pose, self._path)
            return
        for k in np.flatnonzero(active):
            backend = self.envs[int(k)]._backend
            x0, y0 = self._pose[k, 0], self._pose[k, 1]
            self._drives.state[k, :2] = backend.step(
                float(cmd[k, 0]), float(cmd[k, 1]), self.control_dt
            )
            self._pose[k] = backend.pose
            self._path[k] += math.hypot(self._pose[k, 0] - x0, self._pose[k, 1] - y0)

    # ------------------------------------------------------------------ hooks
    def _load_more(self, i: int) -> None:
        """Copy what else the subclass tracks of sub-env ``i``'s fresh episode."""

    def _advance(self, active: np.ndarray) -> None:
        """Move the dynamic parts of the active sub-envs' worlds (after the robots moved)."""

    def _finish(self, active: np.ndarray, rewards: FloatArray, outcome: np.ndarray) -> Any:
        """Batched observation (fresh) of the active sub-envs after sensing, their ``rewards``
        and ``outcome`` codes (0 running, 1 collision, 2 success, 3 timeout; filled in place);
        also counts their step, records (v, w) for the metrics and moves their previous goal
        distance on. Inactive sub-envs get reward 0 and outcome 0 (their rows are overwritten
        by a reset)."""
        raise NotImplementedError

    def _set_row(self, obs: Any, i: int, single: Any) -> None:
        """Put sub-env ``i``'s single observation into the batch."""
        raise NotImplementedError

    # ------------------------------------------------------------------ gym API
    @property
    def np_random_seed(self) -> tuple[int, ...]:  # type: ignore[override]
        """The seeds of the sub-envs' generators."""
        return tuple(env.np_random_seed for env in self.envs)

    @property  # type: ignore[misc]
    def np_random(self) -> tuple[np.random.Generator, ...]:  # type: ignore[override]
        """The sub-envs' generators (each draws its own worlds)."""
        return tuple(env.np_random for env in self.envs)

    def _seeds(self, seed: int | Sequence[int | None] | None) -> list[int | None]:
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            return [int(seed) + i for i in range(self.num_envs)]
        seeds = list(seed)  # type: ignore[arg-type]
        if len(seeds) != self.num_envs:
            raise Sim2RealValueError(
                f"reset(seed=...) needs an int, None or a list of {self.num_envs} seeds "
                f"(one per sub-env), got {len(seeds)}"
            )
        return seeds

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[Any, dict[str, Any]]:
        """Reset every sub-env (or those of ``options["reset_mask"]``); sub-env i gets seed
        ``seed + i``."""
        seeds = self._seeds(seed)
        opts = dict(options or {})
        mask = opts.pop("reset_mask", None)
        if mask is None:
            mask = np.ones(self.num_envs, dtype=np.bool_)
        else:
            mask = np.asarray(mask)
            if mask.shape != (self.num_envs,) or mask.dtype != np.bool_ or not mask.any():
                raise Sim2RealValueError(
                    f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) "
                    f"with at least one True, got {mask!r}"
                )
        infos: dict[str, Any] = {}
        obs = self._copy_obs(self._batch)  # untouched sub-envs keep their last observation
        for i in np.flatnonzero(mask):
            single, info = self.envs[i].reset(seed=seeds[i], options=opts or None)
            self._load_episode(int(i))
            self._set_row(obs, int(i), single)
            infos = self._add_info(infos, info, int(i))
        self._batch = obs
        return self._copy_obs(obs), infos

    def step(self, actions: Any) -> tuple[Any, FloatArray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every sub-env (autoresetting those whose episode ended at the last step)."""
        n = self.num_envs
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (n, 2) or not np.all(np.isfinite(a)):
            raise Sim2RealValueError(
                f"actions must be {n} rows of 2 finite numbers (v [m/s], w [rad/s]), "
                f"got shape {a.shape}" + ("" if a.shape != (n, 2) else " with NaN or inf")
            )
        if not self._was_reset.all():
            missing = np.flatnonzero(~self._was_reset).tolist()
            raise Sim2RealValueError(
                f"step() called before sub-env(s) {missing} were reset; call reset() first"
            )
        cmd = np.clip(a, self._act_low, self._act_high)
        resets = np.flatnonzero(self._autoreset)
        active = ~self._autoreset
        self._move(active, cmd)
        self._advance(active)
        self._sense(active)
        rewards = np.empty(n)
        outcome = np.empty(n, dtype=np.int64)
        obs = self._finish(active, rewards, outcome)
        terminated = (outcome == 1) | (outcome == 2)
        truncated = outcome == 3
        metrics = {int(i): self._metrics(int(i), int(outcome[i])) for i in np.flatnonzero(outcome)}
        reset_infos: list[tuple[int, dict[str, Any]]] = []
        for k in resets:
            i = int(k)
            single, info = self.envs[i].reset()
            self._load_episode(i)
            self._set_row(obs, i, single)
            reset_infos.append((i, info))
        infos = self._step_infos(active, outcome, metrics)
        for j, reset_info in reset_infos:  # keys only a reset gives (common ones are in)
            for key, value in reset_info.items():
                if key not in infos:
                    infos = self._add_info(infos, {key: value}, j)
        self._autoreset = terminated | truncated
        self._batch = obs
        return obs, rewards, terminated, truncated, infos

    def _sense(self, active: np.ndarray) -> None:
        sense(
            active,
            self._pose,
            self._lidar_xy,
            self._beam_angles,
            self._range_min,
            self._range_max,
            self._cxy,
            self._cr,
            self._nc,
            self._sa,
            self._sb,
            self._ns,
            self._goal,
            self._radius,
            self._sensed,
        )

    def _set_beams(self, angles_rad: Any) -> None:
        """Cast the lidar along these beams (rad, in the robot frame)."""
        self._beam_angles = np.asarray(angles_rad, dtype=np.float64)
        ranges = np.zeros((self.num_envs, self._beam_angles.shape[0]))
        self._sensed = self._sensed._replace(ranges=ranges)

    _beam_angles: FloatArray
    _batch: Any

    def _copy_obs(self, obs: Any) -> Any:
        if isinstance(obs, dict):
            return {k: v.copy() for k, v in obs.items()}
        return obs.copy()

    _OUTCOME_KEYS = ("collision", "success", "timeout")

    def _metrics(self, i: int, outcome: int) -> dict[str, Any]:
        """``info["metrics"]`` of sub-env ``i``'s episode, ending now."""
        k = int(self._episodes.steps[i])
        vw = self._episodes.vw_hist[i, : k + 1]
        return episode_metrics(
            self._OUTCOME_KEYS[outcome - 1],
            vw[:, 0],
            vw[:, 1],
            path_length_m=float(self._path[i]),
            control_dt_s=self.control_dt,
        ).to_dict()

    def _step_infos(
        self, active: np.ndarray, outcome: np.ndarray, metrics: dict[int, dict[str, Any]]
    ) -> dict[str, Any]:
        """Vector infos of one step, as gymnasium's SyncVectorEnv gathers the sub-envs' infos."""
        n = self.num_envs
        names = np.full(n, None, dtype=object)
        first = self.envs[0]
        for i in metrics:
            names[i] = first._outcome_name(self._OUTCOME_KEYS[outcome[i] - 1])
        everyone = np.ones(n, dtype=np.bool_)
        infos: dict[str, Any] = {"outcome": names, "_outcome": everyone}
        if active.any():  # a step info (the sub-envs that reset now give their reset info)
            infos["clearance_m"] = np.where(active, self._sensed.clearance, 0.0)
            infos["_clearance_m"] = active.copy()
        for key, column in self._extra.items():
            infos[key] = column.copy()
            infos["_" + key] = everyone.copy()
        for i, m in metrics.items():
            infos = self._add_info(infos, {"metrics": m}, i)
        return infos

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call method ``name`` of every sub-env (read-only use: the arrays hold the state)."""
        out = []
        for env in self.envs:
            attr = getattr(env, name)
            out.append(attr(*args, **kwargs) if callable(attr) else attr)
        return tuple(out)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Attribute ``name`` of every sub-env."""
        return tuple(getattr(env, name) for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()


class RandomMapVectorEnv(NavVectorEnv):
    """``num_envs`` :class:`~sim2real.envs.RandomMapEnv` stepped as arrays (see the module doc).

    Parameters
    ----------
    num_envs : int
        Number of sub-envs.
    **kwargs
        The single env's arguments (``preset``, ``map_config``, ``control_dt``, ...);
        ``dynamics`` must be ``"reduced"`` or ``"plant"``.
    """

    def __init__(self, num_envs: int = 1, **kwargs: Any) -> None:
        n = _check_num_envs(num_envs)
        super().__init__([RandomMapEnv(**kwargs) for _ in range(n)])
        first = self.envs[0]
        assert isinstance(first, RandomMapEnv)
        self._set_beams(first.beam_angles_rad)
        space = first.observation_space
        self._obs_low = np.asarray(space.low, dtype=np.float64)  # type: ignore[attr-defined]
        self._obs_high = np.asarray(space.high, dtype=np.float64)  # type: ignore[attr-defined]
        self._batch = np.zeros((n, *space.shape), dtype=np.float32)  # type: ignore[misc]

    def _set_row(self, obs: Any, i: int, single: Any) -> None:
        obs[i] = single

    def _finish(self, active: np.ndarray, rewards: FloatArray, outcome: np.ndarray) -> Any:
        shape = (self.num_envs, *self.single_observation_space.shape)  # type: ignore[misc]
        obs = np.empty(shape, dtype=np.float32)
        finish_random_map(
            active,
            self._sensed,
            self._drives.state,
            self._episodes,
            self.envs[0].goal_range_m,  # type: ignore[attr-defined]
            self._range_max,
            self._obs_low,
            self._obs_high,
            self._consts,
            obs,
            rewards,
            outcome,
        )
        return obs


class CrowdNavVectorEnv(NavVectorEnv):
    """``num_envs`` :class:`~sim2real.envs.CrowdNavEnv` with their robots, lidars, goals and
    rewards stepped as arrays (see the module doc).

    The eq. (1) pedestrians of all sub-envs walk in one compiled call (``envs.envs[i].crowd``
    holds views of sub-env i's rows, so it shows the current crowd); ORCA crowds step per
    sub-env. The depth images are rendered in one compiled call with each sub-env's camera
    mount; the sub-envs' ``camera.view_matrix`` (pybullet's view matrix, for
    ``get_camera_view_matrix``) is not updated by the vector env.

    Parameters
    ----------
    num_envs : int
        Number of sub-envs.
    **kwargs
        The single env's arguments (``scenario``, ``complexity``, ``pedestrians``, ...);
        ``dynamics`` must be ``"reduced"`` or ``"plant"``.
    """

    def __init__(self, num_envs: int = 1, **kwargs: Any) -> None:
        n = _check_num_envs(num_envs)
        # pedestrians (batched; envs.envs[i].crowd holds views of its rows for eq. (1) crowds)
        xy = ("position_m", "velocity_mps", "goals")
        self._crowds = Crowds(
            **{k: np.zeros((n, 0, 2) if k in xy else (n, 0)) for k in Crowds._fields}
        )
        self._walking = np.zeros((n, 0), dtype=np.bool_)
        self._reached = np.zeros((n, 0), dtype=np.bool_)
        self._any_reached = np.zeros(n, dtype=np.bool_)
        self._n_ped = np.zeros(n, dtype=np.int64)
        self._eq1 = np.zeros(n, dtype=np.bool_)
        self._ped_time = np.zeros(n)
        self._n_static = np.zeros(n, dtype=np.int64)
        # depth scenes: cylinders (x, y, r, h), static first; boxes packed for the renderer
        self._dcyl = np.zeros((n, 0, 4))
        self._n_dcyl = np.zeros(n, dtype=np.int64)
        self._n_dstatic = np.zeros(n, dtype=np.int64)
        self._dbox = np.zeros((n, 0, 8))
        self._n_dbox = np.zeros(n, dtype=np.int64)
        super().__init__([CrowdNavEnv(**kwargs) for _ in range(n)])
        first = self.envs[0]
        assert isinstance(first, CrowdNavEnv)
        if first.neighbour_slots is not None:
            raise Sim2RealValueError(
                f"CrowdNavVectorEnv does not observe neighbours, got neighbours="
                f"{first.neighbour_slots[0]}; use single CrowdNav-v0 envs (SB3's vector envs) "
                "for a crowd-aware policy, or neighbours=0"
            )
        self._set_beams(first.lidar_angles_rad)
        space: Any = first.observation_space
        self._vel_low = np.asarray(space["velocity"].low, dtype=np.float64)
        self._vel_high = np.asarray(space["velocity"].high, dtype=np.float64)
        self._batch = {k: np.zeros((n, *sub.shape), dtype=sub.dtype) for k, sub in space.items()}
        self._prev_vw = np.zeros((n, 2))
        self._camera = first.camera
        self._cam_xyz = np.zeros((n, 3))
        self._cam_mount = np.zeros((n, 3, 3))
        self._frame = np.zeros((first.camera.height, first.camera.width))

    def _load_more(self, i: int) -> None:
        env = self.envs[i]
        assert isinstance(env, CrowdNavEnv) and env.crowd is not None
        self._prev_vw[i] = env._prev_velocity
        crowd = env.crowd
        m = len(crowd)
        self._eq1[i] = False  # not bound to the rows until copied
        slots = self._crowds.position_m.shape[1]
        if m > slots:
            self._grow_crowds(max(m, 2 * slots))
        self._n_ped[i] = m
        self._eq1[i] = type(crowd) is Crowd
        self._ped_time[i] = crowd.time_s
        for name, column in self._crowds._asdict().items():
            column[i, :m] = getattr(crowd, name)
        self._n_static[i] = env._scene.circles_r.shape[0]
        self._load_depth(i)
        if self._eq1[i]:
            self._bind_crowd(i)

    def _grow_crowds(self, cap: int) -> None:
        """Room for ``cap`` pedestrians per sub-env (the eq. (1) crowds' views follow)."""
        n = self.num_envs
        self._crowds = Crowds(*(_with_room(column, cap) for column in self._crowds))
        self._walking = np.zeros((n, cap), dtype=np.bool_)
        self._reached = np.zeros((n, cap), dtype=np.bool_)
        for i in np.flatnonzero(self._eq1 & self._was_reset):
            self._bind_crowd(int(i))

    def _bind_crowd(self, i: int) -> None:
        """Make sub-env ``i``'s eq. (1) crowd hold views of its rows: ``envs.envs[i].crowd``
        shows the state the vector env steps."""
        crowd = self.envs[i].crowd  # type: ignore[attr-defined]
        m = int(self._n_ped[i])
        for name, column in self._crowds._asdict().items():
            setattr(crowd, name, column[i, :m])

    def _load_depth(self, i: int) -> None:
        """Copy sub-env ``i``'s depth scene (static bodies, then pedestrians) into the arrays."""
        env = self.envs[i]
        assert isinstance(env, CrowdNavEnv)
        cyl, boxes = env._depth_scene.cylinders, _packed_boxes(env._depth_static.boxes)
        if cyl.shape[0] > self._dcyl.shape[1]:
            self._dcyl = _with_room(self._dcyl, max(cyl.shape[0], 2 * self._dcyl.shape[1]))
        if boxes.shape[0] > self._dbox.shape[1]:
            self._dbox = _with_room(self._dbox, max(boxes.shape[0], 2 * self._dbox.shape[1]))
        self._dcyl[i, : cyl.shape[0]] = cyl
        self._n_dcyl[i] = cyl.shape[0]
        self._n_dstatic[i] = env._depth_static.cylinders.shape[0]
        self._dbox[i, : boxes.shape[0]] = boxes
        self._n_dbox[i] = boxes.shape[0]

    def _set_row(self, obs: Any, i: int, single: Any) -> None:
        for key, value in single.items():
            obs[key][i] = value

    def _advance(self, active: np.ndarray) -> None:
        """The pedestrians of each active sub-env walk: eq. (1) crowds all at once in compiled
        loops (the single env's kernel), other policies (ORCA) by the sub-env's own crowd."""
        eq1 = active & self._eq1
        if eq1.any():
            crowd_clock(
                eq1,
                self.control_dt,
                self._ped_time,
                self._n_ped,
                self._crowds,
                _GOAL_REACHED_M,
                self._walking,
                self._reached,
                self._any_reached,
            )
            for k in np.flatnonzero(self._any_reached):  # new goals from the sub-env's stream
                i = int(k)
                crowd = self.envs[i].crowd  # type: ignore[attr-defined]
                reached = self._reached[i, : self._n_ped[i]]
                crowd.goals[reached] = crowd._random_goals(int(reached.sum()))
            to_goal = self._crowds.goals - self._crowds.position_m
            goal_dir = np.arctan2(to_goal[..., 1], to_goal[..., 0])  # numpy's, as the single env
            walk_crowds(
                eq1,
                self._n_ped,
                self._crowds,
                self._walking,
                goal_dir,
                self._cxy,
                self._cr,
                self._n_static,
                self._sa,
                self._sb,
                self._ns,
                self._pose,
                self._radius,
                self.control_dt,
                _HEADING_OFFSETS,
                _COS_OFFSETS,
                _OFFSET_PENALTY,
                self._dcyl,
                self._n_dstatic,
            )
            for k in np.flatnonzero(eq1):
                self.envs[int(k)].crowd.time_s = float(self._ped_time[k])  # type: ignore[attr-defined]
        for k in np.flatnonzero(active & ~self._eq1):
            i = int(k)
            env = self.envs[i]
            assert isinstance(env, CrowdNavEnv) and env.crowd is not None
            x, y, yaw = (float(c) for c in self._pose[i])
            v = float(self._drives.state[i, 0])
            env.crowd.step(
                self.control_dt,
                env._scene,
                robot_xy=np.array([x, y]),
                robot_radius_m=env.robot_radius_m,
                robot_velocity_mps=np.array([v * math.cos(yaw), v * math.sin(yaw)]),
            )
            env._sync_pedestrians()
            self._load_scene(i, env._full_scene)
            self._load_depth(i)

    def _finish(self, active: np.ndarray, rewards: FloatArray, outcome: np.ndarray) -> Any:
        n = self.num_envs
        space: Any = self.single_observation_space
        obs = {k: np.empty((n, *sub.shape), dtype=sub.dtype) for k, sub in space.items()}
        finish_crowd_nav(
            active,
            self._sensed,
            self._drives.state,
            self._episodes,
            self._prev_vw,
            self._vel_low,
            self._vel_high,
            self._consts,
            obs["lidar"],
            obs["goal"],
            obs["velocity"],
            rewards,
            outcome,
        )
        for k in np.flatnonzero(active):  # each sub-env's camera mount (set_camera_pose)
            camera = self.envs[int(k)].camera  # type: ignore[attr-defined]
            self._cam_xyz[k] = camera.xyz_m
            self._cam_mount[k] = camera._r_mount
        cam = self._camera
        render_depths(
            active,
            self._pose,
            cam.base_height_m,
            self._cam_xyz,
            self._cam_mount,
            cam._rays,
            self._dcyl,
            self._n_dcyl,
            self._dbox,
            self._n_dbox,
            cam.near_m,
            cam.far_m,
            self._frame,
            obs["depth"],
        )
        return obs
