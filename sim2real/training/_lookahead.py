r"""SARL's value network with a one-step look-ahead, as a stable-baselines3 DQN policy.

Chen et al. (2019) act by :math:`a_t = \arg\max_a R(s_t, a) + \gamma^{\Delta t\, v_{pref}}
V(\hat s^a_{t+\Delta t})`: every action's next joint state is predicted (the robot by its
kinematics, the humans at constant velocity) and scored by the attention network's value
:math:`V`, so that a manoeuvre is judged by where the others will be, not where they are.
``policy: sarl-lookahead`` makes that the Q-network of DQN on a Race-v0 observation:

.. math::

    Q(s, a) = V(f(s, a)), \qquad V = \text{head} \circ \text{SarlExtractor}

with :math:`f` the one-step look-ahead of the observation under grid command :math:`a = (v,
w)` over one control step :math:`\Delta t`:

- the robot (``motion_model``): ``"drive"`` runs the env's own drive model
  (:func:`robots._kernel.drive_step` with the env's drive parameters, the chain of the
  ``reduced`` back-end) over the step from the observed (v, w): for the transport delay the
  robot keeps the observed velocity (the previous command, held for a whole step, has
  reached its steady state), then the drive responds to the new command (its clamps, wheel
  loops, torque cap and friction), and the pose follows the velocity's arcs; the measured
  (v, w) becomes the drive's velocity at the end of the step. The Burger's P wheel loops
  with friction hold a turn below the command (0.2 rad/s -> about 0.12 at full speed): the
  drive model predicts where the robot will be, the command model does not. ``"command"``
  drives the arc of :math:`(v, w)` with the command taken as reached and the command as the
  measured (v, w) (the model of policies saved without ``motion_model``). What the
  observation does not hold is assumed: the velocity-smoother's reference starts at the
  observed velocity and the wheel loops' integrators at zero (exact for the Burger: no
  acceleration limit, P loops);
- the goal point (distance, bearing) is the same point seen from the new pose (SARL*'s local
  goal moves on along the plan as the robot drives; the prediction keeps the point);
- each observed mover moves at its observed velocity (constant-velocity prediction) and is seen
  from the new pose, its relative velocity against the commanded one; empty slots stay empty;
- the lidar (``lidar_model``): ``"recast"`` joins neighbouring returns into segments (the
  scan as a polygon) and casts every beam of the new pose against them, so a wall seen by two
  neighbouring beams keeps its place and each new beam meets it where a real ray would (exact
  for a straight wall, a chord for a curved one); a beam that meets no segment (beside a
  single return or a gap) takes the ``"point"`` value. ``"point"`` moves every return as a
  point: its range is its distance from the new pose, placed at its beam angle minus the
  turn, interpolated between beams; exact for a small obstacle, while a wall parallel to the
  motion comes out nearer ahead and farther behind by up to the step's 5.5 cm. Either way a
  mover inside the scan stays where it was seen (its motion is in the neighbour rows) and the
  lidar's 3 cm offset from the robot's centre is neglected.

:math:`V(f(s, a))` is the value of the predicted post-decision state (an afterstate, Sutton and
Barto 2018, section 6.8): DQN's target :math:`r + \gamma \max_{a'} Q(s', a')` trains it through
the look-ahead, the step reward :math:`R` is learned into it rather than computed, and the
greedy action is SARL's arg max over the discrete set. The network sees one observation per
action (the 3 x 7 grid: 21), so a step costs 21 forward passes of the SARL network. The
prediction itself is one compiled loop (numba) over observations, actions and beams;
:meth:`RaceLookahead.predict_reference` is the ``"point"`` lidar with the ``"command"`` motion in
torch operations.

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> env = gym.make("sim2real/Race-v0", track="open", num_opponents=2, control_dt=0.25)
>>> model = race_lookahead(env, v_mps=[0.0, 0.22], w_radps=[-1.0, 0.0, 1.0])
>>> obs, _ = env.reset(seed=0)
>>> nxt = model.predict(torch.as_tensor(obs)[None])
>>> tuple(nxt.shape), round(float(nxt[0, 4, 36] - obs[36]), 3)  # (0.22, 0) from rest, m
((1, 6, 63), 0.032)

(5.5 cm at full speed; from rest the delay and the drive's acceleration leave 3.2 cm, as the
env's step does.)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
import numba
import numpy as np
import torch
from stable_baselines3.common.preprocessing import preprocess_obs
from stable_baselines3.common.torch_layers import create_mlp
from stable_baselines3.dqn.policies import DQNPolicy, QNetwork
from torch import nn

import robots._kernel
from robots import _jit
from robots._kernel import N_PACKED, SPEED_V, drive_step, pack_params
from robots.reduced import DEFAULT_DT_S
from sim2real.envs import _robot
from sim2real.envs._robot import arc_step
from sim2real.envs.geometry import FloatArray
from sim2real.envs.race import N_BEAMS, N_NEIGHBOURS, RaceEnv
from sim2real.errors import Sim2RealValueError

#: Values of the robot's own block (x, y, yaw, v, w, goal distance, goal bearing).
_OWN = 7
#: The lidar models of :class:`RaceLookahead` (see the module docstring).
LIDAR_MODELS = ("point", "recast")
#: The motion models of :class:`RaceLookahead` (see the module docstring).
MOTION_MODELS = ("command", "drive")
#: Observed velocities whose driven motions :meth:`RaceLookahead.motions` keeps (21 commands:
#: 840 bytes each).
_MOTION_CACHE = 100_000

__all__ = [
    "LIDAR_MODELS",
    "MOTION_MODELS",
    "LookaheadDQNPolicy",
    "LookaheadQNetwork",
    "RaceLookahead",
    "lookahead_kwargs",
    "race_lookahead",
]


def race_lookahead(
    env: gym.Env[Any, Any],
    *,
    v_mps: Sequence[float],
    w_radps: Sequence[float],
    where: str = "env",
    models: Any = None,
) -> RaceLookahead:
    """The look-ahead of ``env``'s observation over the (v, w) grid (``discrete_actions``).

    ``models``: a config's ``hyperparameters.policy_kwargs.lookahead``, a mapping that may
    choose ``lidar_model`` (default ``"recast"``) and ``motion_model`` (default ``"drive"``,
    with the env's drive parameters). Raises one sentence for an env other than Race-v0 (the
    look-ahead needs the layout and the lidar of its observation) and for another key.
    """
    chosen = _chosen_models(models, where)
    base = env.unwrapped
    if not isinstance(base, RaceEnv):
        name = base.spec.id if base.spec is not None else type(base).__name__
        raise Sim2RealValueError(
            f"{where}: policy 'sarl-lookahead' predicts the next Race-v0 observation (lidar, "
            f"pose, goal and the nearest movers), but the env is {name}; use "
            "sim2real/Race-v0, or policy sarl"
        )
    lidar = base.robot_spec.lidar
    grid = [(float(v), float(w)) for v in v_mps for w in w_radps]
    drive = base.get_drive_params()
    return RaceLookahead(
        v_mps=tuple(v for v, _ in grid),
        w_radps=tuple(w for _, w in grid),
        control_dt_s=float(base.control_dt),
        beam_angles_rad=tuple(float(a) for a in base.beam_angles_rad),
        range_min_m=float(lidar.range_min_m),
        range_max_m=float(lidar.range_max_m),
        lidar_model=chosen.get("lidar_model", "recast"),
        motion_model=chosen.get("motion_model", "drive"),
        drive_packed=tuple(float(x) for x in pack_params(drive, base.robot_spec.geometry)),
        drive_delay_s=float(drive.delay_s),
        drive_timeout_s=float(drive.cmd_timeout_s),
    )


def _chosen_models(models: Any, where: str) -> dict[str, str]:
    """``race_lookahead``'s ``models`` as a dict, or one sentence naming what is wrong."""
    key = "hyperparameters.policy_kwargs.lookahead"
    if models is None:
        return {}
    if not isinstance(models, dict):
        raise Sim2RealValueError(
            f"{where}: key '{key}' must be a mapping, got {models!r}; e.g. "
            "{motion_model: command}"
        )
    for name, value in models.items():
        if name not in ("lidar_model", "motion_model"):
            raise Sim2RealValueError(
                f"{where}: key '{key}' has {name!r}, which the look-ahead does not take; use "
                f"lidar_model ({' or '.join(LIDAR_MODELS)}) or motion_model "
                f"({' or '.join(MOTION_MODELS)})"
            )
        choices = LIDAR_MODELS if name == "lidar_model" else MOTION_MODELS
        if value not in choices:
            raise Sim2RealValueError(
                f"{where}: key '{key}.{name}' is {value!r}, which is not one of "
                f"{', '.join(choices)}; the default is {choices[-1]!r}"
            )
    return dict(models)


@dataclass(frozen=True, kw_only=True)
class RaceLookahead:
    """The one-step look-ahead of a Race-v0 observation over a discrete (v, w) grid.

    Parameters
    ----------
    v_mps, w_radps : tuple of float
        The grid's commands in action order: action k is (v_mps[k], w_radps[k]), m/s and rad/s.
    control_dt_s : float
        Control step, s.
    beam_angles_rad : tuple of float
        Lidar beam angles in the robot frame, rad, evenly spaced over a full turn.
    range_min_m, range_max_m : float
        Lidar range limits, m (a reading at ``range_max_m`` is no return).
    neighbours, neighbour_features : int
        Neighbour slots at the end of the observation and values per slot (x, y, vx, vy).
    lidar_model : {"point", "recast"}
        How the scan is predicted (module docstring); :func:`race_lookahead` gives
        ``"recast"``, and a saved model without the key keeps ``"point"``.
    motion_model : {"command", "drive"}
        How the robot moves over the step (module docstring); :func:`race_lookahead` gives
        ``"drive"``, and a saved model without the key keeps ``"command"``.
    drive_packed : tuple of float
        ``"drive"`` only: the env's drive parameters packed for the drive kernel
        (:func:`robots._kernel.pack_params` of the drive parameters and the base geometry).
    drive_delay_s, drive_timeout_s : float
        ``"drive"`` only: the command's transport delay and the time a command holds, s.
    drive_step_s : float
        ``"drive"`` only: the drive model's integration step, s (the reduced model's).
    """

    v_mps: tuple[float, ...]
    w_radps: tuple[float, ...]
    control_dt_s: float
    beam_angles_rad: tuple[float, ...]
    range_min_m: float
    range_max_m: float
    neighbours: int = N_NEIGHBOURS
    neighbour_features: int = 4
    lidar_model: str = "point"
    motion_model: str = "command"
    drive_packed: tuple[float, ...] = ()
    drive_delay_s: float = 0.0
    drive_timeout_s: float = math.inf
    drive_step_s: float = DEFAULT_DT_S

    def __post_init__(self) -> None:
        if self.lidar_model not in LIDAR_MODELS:
            raise Sim2RealValueError(
                f"policy 'sarl-lookahead': lidar_model is {self.lidar_model!r}, which is not "
                f"one of {', '.join(LIDAR_MODELS)}; use 'recast'"
            )
        if self.motion_model not in MOTION_MODELS:
            raise Sim2RealValueError(
                f"policy 'sarl-lookahead': motion_model is {self.motion_model!r}, which is not "
                f"one of {', '.join(MOTION_MODELS)}; use 'drive'"
            )
        if self.motion_model == "drive" and len(self.drive_packed) != N_PACKED:
            raise Sim2RealValueError(
                f"policy 'sarl-lookahead': motion_model 'drive' needs the {N_PACKED} packed "
                f"drive parameters in drive_packed, got {len(self.drive_packed)}; build the "
                "look-ahead with race_lookahead(env, ...)"
            )

    @cached_property
    def _kernel_args(
        self,
    ) -> tuple[tuple[float, float, float, int, int], FloatArray, FloatArray, FloatArray]:
        """:func:`predict_kernel`'s sizes, commands and beams, and :func:`driven_arcs`' drive."""
        angles = np.asarray(self.beam_angles_rad, dtype=np.float64)
        commands = np.column_stack([self.arcs().numpy(), self.v_mps, self.w_radps])
        window = self.recast_window() if self.lidar_model == "recast" else -1
        sizes = (
            float(self.control_dt_s),
            float(self.range_min_m),
            float(self.range_max_m),
            int(self.neighbour_features),
            window,
        )
        beams = np.column_stack([np.cos(angles), np.sin(angles)])
        drive = np.array(
            [self.drive_delay_s, self.drive_timeout_s, self.drive_step_s, *self.drive_packed]
            if self.motion_model == "drive"
            else [],
            dtype=np.float64,
        )
        return sizes, np.ascontiguousarray(commands, dtype=np.float64), beams, drive

    def recast_window(self) -> int:
        """Segments on either side of a beam's turned index that a re-cast beam can meet.

        A step moves the lidar by at most the longest chord d, which turns the bearing of a
        point of the scan's polygon (at least ``range_min_m cos(beam step / 2)`` away) by at
        most asin(d / that distance): a ray meets no segment whose beams lie farther round.
        The kernel narrows it for each observation and command, by the scan's nearest return
        and the command's own chord (none for a turn on the spot).
        """
        n = len(self.beam_angles_rad)
        step = 2 * math.pi / n
        chord = float(self.arcs()[:, :2].norm(dim=1).max())
        if self.motion_model == "drive":  # no faster than the drive's speed limit
            chord = max(chord, self.drive_packed[SPEED_V] * self.control_dt_s)
        return min(n // 2, _turned_beams(chord, self.range_min_m * math.cos(step / 2), step))

    def held_velocity(self, v_mps: float, w_radps: float, steps: int = 40) -> tuple[float, float]:
        """The (v m/s, w rad/s) the ``"drive"`` motion settles at when command (``v_mps``,
        ``w_radps``) is held for ``steps`` control steps from rest (each step as the
        look-ahead predicts it, :func:`driven_arc`).

        Examples
        --------
        >>> import gymnasium as gym
        >>> import sim2real.envs
        >>> look = race_lookahead(gym.make("sim2real/Race-v0"), v_mps=[0.22], w_radps=[0.0])
        >>> [round(x, 3) for x in look.held_velocity(0.22, 0.2)]  # the Burger turns less
        [0.214, 0.123]
        """
        if self.motion_model != "drive":
            return float(v_mps), float(w_radps)  # the command is taken as reached
        _jit.compile_all()  # robots' drive kernel, bound before numba types ours
        drive = self._kernel_args[3]
        v, w = 0.0, 0.0
        for _ in range(steps):
            *_, v, w = driven_arc(v, w, float(v_mps), float(w_radps), self.control_dt_s, drive)
        return float(v), float(w)

    def holding_turn_radps(self, v_mps: float, radius_m: float) -> float:
        """The commanded turn (rad/s, >= 0) whose held motion at command speed ``v_mps``
        drives a circle of ``radius_m`` m: held w = held v / radius.

        The held turn grows with the command (the wheel loops hold a fixed share of it above
        the friction's dead band), so bisection on the command finds it to 1e-6 rad/s; the
        ``"command"`` motion returns ``v_mps / radius_m``.

        Examples
        --------
        >>> import gymnasium as gym
        >>> import sim2real.envs
        >>> look = race_lookahead(gym.make("sim2real/Race-v0"), v_mps=[0.22], w_radps=[0.0])
        >>> round(look.holding_turn_radps(0.22, 1.5), 3)  # the curve track's 1.5 m bend
        0.22
        """
        if not radius_m > 0.0:
            raise Sim2RealValueError(
                f"holding_turn_radps: radius_m is {radius_m!r}, but a circle needs a radius "
                "above 0 m; pass the curve's radius"
            )

        def short(w_cmd: float) -> float:  # held turn minus the circle's, rad/s
            v, w = self.held_velocity(v_mps, w_cmd)
            return w - v / radius_m

        lo, hi = 0.0, max(1.0, 2.0 * v_mps / radius_m)
        while short(hi) < 0.0:
            if hi > 1e3:
                raise Sim2RealValueError(
                    f"holding_turn_radps: no command up to {hi:.0f} rad/s holds a circle of "
                    f"{radius_m} m at {v_mps} m/s with this drive; pass a larger radius_m"
                )
            lo, hi = hi, 2.0 * hi
        while hi - lo > 1e-6:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if short(mid) < 0.0 else (lo, mid)
        return 0.5 * (lo + hi)

    def predict(self, obs: torch.Tensor) -> torch.Tensor:
        """Observations (batch, 63) -> their predicted successors (batch, actions, 63).

        One compiled pass (:func:`predict_kernel`), in the observations' dtype; no gradient
        (the prediction is a fixed model of the world, not learned).
        """
        flat = np.ascontiguousarray(obs.detach().cpu().numpy(), dtype=np.float64)
        out = np.empty((flat.shape[0], len(self.v_mps), flat.shape[1]))
        sizes, _, beams, _ = self._kernel_args
        predict_kernel(flat, sizes, beams, self.motions(flat), out)
        return torch.from_numpy(out).to(obs.dtype)

    def motions(self, flat: FloatArray) -> FloatArray:
        """Each observation's motion under each command: (batch, actions, 5), the
        displacement dx, dy (m, start frame), turn (rad) and end (v m/s, w rad/s).

        The ``"drive"`` motion depends on the observed (v, w) and the command alone, so the
        grid's motions from each observed velocity are computed once (:func:`driven_arcs`) and
        kept, keyed by its exact (v, w): a replayed or repeated velocity (a command held for a
        step ends at the same measured velocity) reuses them, bit for bit the same numbers.
        At most ``_MOTION_CACHE`` velocities are kept; past that the store starts afresh.
        """
        n_beams = len(self.beam_angles_rad)
        _, commands, _, drive = self._kernel_args
        if self.motion_model != "drive":
            table = commands  # the arc of each command taken as reached, then v and w
            return np.ascontiguousarray(np.broadcast_to(table, (flat.shape[0], *table.shape)))
        store = self._motion_store
        keys = [(float(v), float(w)) for v, w in flat[:, n_beams + 3 : n_beams + 5]]
        new = list(dict.fromkeys(k for k in keys if k not in store))
        if new:
            if len(store) + len(new) > _MOTION_CACHE:
                store.clear()
            _jit.compile_all()  # robots' drive kernel, bound before numba types ours
            fresh = np.empty((len(new), len(commands), 5))
            driven_arcs(np.array(new), commands, self.control_dt_s, drive, fresh)
            store.update(zip(new, fresh, strict=True))
        return np.stack([store[k] for k in keys]) if keys else np.empty((0, len(commands), 5))

    @cached_property
    def _motion_store(self) -> dict[tuple[float, float], FloatArray]:
        """:meth:`motions`' store: observed (v, w) -> (actions, 5)."""
        return {}

    def arcs(self) -> torch.Tensor:
        """(actions, 3): each command's displacement dx, dy (m, robot frame) and turn (rad),
        the command taken as reached (the ``"command"`` motion model)."""
        v = torch.tensor(self.v_mps, dtype=torch.float64)
        turn = torch.tensor(self.w_radps, dtype=torch.float64) * self.control_dt_s
        chord = v * self.control_dt_s * torch.sinc(turn / (2 * math.pi))  # 2 v/w sin(w dt/2)
        return torch.stack([chord * torch.cos(turn / 2), chord * torch.sin(turn / 2), turn], 1)

    def predict_reference(self, obs: torch.Tensor) -> torch.Tensor:
        """:meth:`predict` with the ``"point"`` lidar and the ``"command"`` motion in torch
        operations (the tests' and the benchmark's reference): (batch, 63) -> (batch, actions,
        63)."""
        arcs = self.arcs().to(obs.dtype)
        dx, dy, turn = (arcs[:, i][None] for i in range(3))  # (1, A)
        c, s = torch.cos(turn), torch.sin(turn)
        n_act = arcs.shape[0]
        lidar = self._lidar(obs[:, :N_BEAMS], dx, dy, c, s, turn)
        own = obs[:, N_BEAMS : N_BEAMS + _OWN]
        x, y, yaw, v, _, goal_d, bearing = (own[:, i : i + 1] for i in range(_OWN))
        cy, sy = torch.cos(yaw), torch.sin(yaw)
        new_yaw = torch.atan2(torch.sin(yaw + turn), torch.cos(yaw + turn))
        gx, gy = goal_d * torch.cos(bearing) - dx, goal_d * torch.sin(bearing) - dy
        gx, gy = c * gx + s * gy, -s * gx + c * gy
        cmd_v = torch.tensor(self.v_mps, dtype=obs.dtype)[None].expand(obs.shape[0], -1)
        cmd_w = torch.tensor(self.w_radps, dtype=obs.dtype)[None].expand(obs.shape[0], -1)
        own_next = torch.stack(
            [
                x + dx * cy - dy * sy,
                y + dx * sy + dy * cy,
                new_yaw,
                cmd_v,
                cmd_w,
                torch.hypot(gx, gy),
                torch.atan2(gy, gx),
            ],
            dim=-1,
        )
        rows = obs[:, N_BEAMS + _OWN :].reshape(obs.shape[0], 1, -1, self.neighbour_features)
        present = (rows.abs().sum(-1) > 0).to(obs.dtype)  # (B, 1, K)
        ux, uy = rows[..., 2] + v[..., None], rows[..., 3]  # mover velocity, old robot frame
        qx = rows[..., 0] + ux * self.control_dt_s - dx[..., None]
        qy = rows[..., 1] + uy * self.control_dt_s - dy[..., None]
        cc, ss = c[..., None], s[..., None]
        movers = (
            torch.stack(
                [
                    cc * qx + ss * qy,
                    -ss * qx + cc * qy,
                    cc * ux + ss * uy - cmd_v[..., None],
                    -ss * ux + cc * uy,
                ],
                dim=-1,
            )
            * present[..., None]
        )
        return torch.cat([lidar, own_next, movers.flatten(2)], dim=-1).reshape(
            obs.shape[0], n_act, -1
        )

    def _lidar(
        self,
        ranges: torch.Tensor,
        dx: torch.Tensor,
        dy: torch.Tensor,
        c: torch.Tensor,
        s: torch.Tensor,
        turn: torch.Tensor,
    ) -> torch.Tensor:
        """Scans (B, N) -> (B, A, N): every return seen from each action's new pose."""
        angles = torch.tensor(self.beam_angles_rad, dtype=ranges.dtype)
        px = (ranges * torch.cos(angles))[:, None] - dx[..., None]
        py = (ranges * torch.sin(angles))[:, None] - dy[..., None]
        seen = torch.hypot(
            c[..., None] * px + s[..., None] * py, -s[..., None] * px + c[..., None] * py
        )
        seen = torch.where(ranges[:, None] >= self.range_max_m - 1e-6, self.range_max_m, seen)
        # a return at beam angle theta lies near theta - turn from the new pose: resample
        shift = turn[0] / (2 * math.pi / len(self.beam_angles_rad))  # (A,) in beams
        base = torch.floor(shift)
        frac = (shift - base)[None, :, None]
        n = len(self.beam_angles_rad)
        idx0 = (torch.arange(n)[None] + base.long()[:, None]) % n  # (A, N)
        idx1 = (idx0 + 1) % n
        expand = (ranges.shape[0], -1, -1)
        lo = torch.gather(seen, 2, idx0[None].expand(*expand))
        hi = torch.gather(seen, 2, idx1[None].expand(*expand))
        return ((1 - frac) * lo + frac * hi).clamp(self.range_min_m, self.range_max_m)


@numba.njit(cache=True)
def _turned_beams(chord_m: float, nearest_m: float, beam_step_rad: float) -> int:
    """Beams by which a move of ``chord_m`` can turn the bearing of a point ``nearest_m`` or
    more away: ceil(asin(chord / nearest) / beam step), a full half turn if it is nearer."""
    if chord_m <= 0.0:
        return 0
    if chord_m >= nearest_m:
        return int(math.pi / beam_step_rad)
    return math.ceil(math.asin(chord_m / nearest_m) / beam_step_rad)


@numba.njit(cache=True, inline="always")
def _polygon_hit(
    qx: FloatArray, qy: FloatArray, ok: Any, first: int, count: int, ux: float, uy: float
) -> float:  # pragma: no cover - compiled
    """Distance from the origin along the unit direction (ux, uy) to the nearest of the
    ``count`` segments from vertex ``first`` (vertex g to g + 1, both returns), or inf.

    The ray t u meets the segment q_g + s e (e = q_{g+1} - q_g) at t = (q_g x e) / (u x e),
    s = (q_g x u) / (u x e), taken when t >= 0 and 0 <= s <= 1 (the numerators compared
    with the denominator's sign before dividing).
    """
    best = math.inf
    for g in range(first, first + count):
        if not (ok[g] and ok[g + 1]):
            continue
        ex, ey = qx[g + 1] - qx[g], qy[g + 1] - qy[g]
        denom = ux * ey - uy * ex
        t_num = qx[g] * ey - qy[g] * ex
        s_num = qx[g] * uy - qy[g] * ux
        if denom < 0.0:
            denom, t_num, s_num = -denom, -t_num, -s_num
        if denom > 0.0 and t_num >= 0.0 and 0.0 <= s_num <= denom and t_num < best * denom:
            best = t_num / denom
    return best


_arc_step = numba.njit(cache=True)(arc_step)


@numba.njit(cache=True)
def driven_arc(
    v0: float, w0: float, cmd_v: float, cmd_w: float, dt_s: float, drive: FloatArray
) -> tuple[float, float, float, float, float]:  # pragma: no cover - compiled
    """The robot's motion over ``dt_s`` s under command (``cmd_v`` m/s, ``cmd_w`` rad/s) from
    velocity (``v0``, ``w0``): (dx, dy m in the start frame, turn rad, v m/s, w rad/s at the end).

    ``drive``: the transport delay, the command's hold time and the integration step (s),
    then the packed drive parameters. For the delay the velocity holds (the previous command
    at its steady state); then :func:`robots._kernel.drive_step` responds to the command
    (zero once it has held ``drive[1]`` s), the velocity-smoother's reference starting at
    (``v0``, ``w0``) and the integrators at zero; the pose moves on the arc of each step's
    mean velocity (:func:`sim2real.envs._robot.arc_step`).
    """
    delay_s, timeout_s, step_s = drive[0], drive[1], drive[2]
    p = drive[3:]
    hold = min(delay_s, dt_s)
    x, y, yaw = _arc_step(0.0, 0.0, 0.0, v0, w0, hold)
    n = max(0, math.ceil((dt_s - hold) / step_s - 1e-9))
    h = (dt_s - hold) / max(n, 1)
    v, w, ref_v, ref_w, ir, il = v0, w0, v0, w0, 0.0, 0.0
    for k in range(n):
        on = k * h < timeout_s
        v1, w1, ref_v, ref_w, ir, il, _, _ = drive_step(
            v, w, ref_v, ref_w, ir, il, cmd_v if on else 0.0, cmd_w if on else 0.0, h, p
        )
        x, y, yaw = _arc_step(x, y, yaw, 0.5 * (v + v1), 0.5 * (w + w1), h)
        v, w = v1, w1
    return x, y, yaw, v, w


@numba.njit(cache=True)
def driven_arcs(
    vw: FloatArray, commands: FloatArray, dt_s: float, drive: FloatArray, out: FloatArray
) -> None:  # pragma: no cover - compiled
    """:func:`driven_arc` from each velocity ``vw`` (U, 2: v m/s, w rad/s) under each command
    (``commands``' columns 3 and 4: v, w) into ``out`` (U, A, 5)."""
    for u in range(vw.shape[0]):
        for a in range(commands.shape[0]):
            dx, dy, turn, v, w = driven_arc(
                vw[u, 0], vw[u, 1], commands[a, 3], commands[a, 4], dt_s, drive
            )
            out[u, a, 0] = dx
            out[u, a, 1] = dy
            out[u, a, 2] = turn
            out[u, a, 3] = v
            out[u, a, 4] = w


@numba.njit(cache=True)
def predict_kernel(
    obs: FloatArray,
    sizes: tuple[float, float, float, int, int],
    beams: FloatArray,
    motions: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    """:meth:`RaceLookahead.predict` into ``out`` (B, A, D): observations ``obs`` (B, D);
    ``sizes``: the control step, the lidar's range limits, the values per neighbour slot and
    the re-cast ``window`` (segments on either side of a beam,
    :meth:`RaceLookahead.recast_window`; negative: the ``"point"`` lidar); ``beams`` (N, 2: each
    angle's cos, sin) and
    ``motions`` (B, A, 5: each observation's motion under each command, dx, dy, turn, end v
    and w; :meth:`RaceLookahead.motions`)."""
    dt_s, range_min_m, range_max_m, features, window = sizes
    cos_b, sin_b = beams[:, 0], beams[:, 1]
    n = cos_b.shape[0]
    beam_step = 2.0 * math.pi / n
    recast = window >= 0
    # the scan's returns in the new robot frame, vertex g being return (g - window) mod n, so
    # that the segments within a window of a beam (vertex g to g + 1) are consecutive
    pad = n + 2 * max(window, 0) + 1
    ring_x, ring_y, ok = np.empty(pad), np.empty(pad), np.empty(pad, dtype=np.bool_)
    seen = np.empty(n)
    for b in range(obs.shape[0]):
        nearest = range_max_m  # the scan's nearest return, for each command's own window
        for i in range(n):
            nearest = min(nearest, obs[b, i])
        nearest *= math.cos(beam_step / 2)  # the nearest point of the scan's polygon
        x, y, yaw, v = obs[b, n], obs[b, n + 1], obs[b, n + 2], obs[b, n + 3]
        goal_d, bearing = obs[b, n + 5], obs[b, n + 6]
        cy, sy = math.cos(yaw), math.sin(yaw)
        for a in range(motions.shape[1]):
            dx, dy, turn = motions[b, a, 0], motions[b, a, 1], motions[b, a, 2]
            v_next, w_next = motions[b, a, 3], motions[b, a, 4]
            c, s = math.cos(turn), math.sin(turn)
            # lidar: every return as a point seen from the new pose, then resampled
            for i in range(n):
                r = obs[b, i]
                if r >= range_max_m - 1e-6:
                    seen[i] = range_max_m
                else:
                    px, py = r * cos_b[i] - dx, r * sin_b[i] - dy
                    seen[i] = math.sqrt(px * px + py * py)
            if recast:
                chord = math.sqrt(dx * dx + dy * dy)
                near = min(window, _turned_beams(chord, nearest, beam_step))
                for g in range(pad):
                    i = (g - window) % n
                    r = obs[b, i]
                    ok[g] = r < range_max_m - 1e-6
                    px, py = r * cos_b[i] - dx, r * sin_b[i] - dy
                    ring_x[g], ring_y[g] = c * px + s * py, -s * px + c * py
            shift = turn / beam_step
            base = math.floor(shift)
            frac = shift - base
            for j in range(n):
                i0 = (j + int(base)) % n
                value = (1.0 - frac) * seen[i0] + frac * seen[(i0 + 1) % n]
                value = min(max(value, range_min_m), range_max_m)
                if recast:  # segments from returns i0 - near .. i0 + near
                    t = _polygon_hit(
                        ring_x, ring_y, ok, i0 + window - near, 2 * near + 1, cos_b[j], sin_b[j]
                    )
                    if t < math.inf:  # the sensor reads a return below its minimum as none
                        value = range_max_m if t < range_min_m or t > range_max_m else t
                out[b, a, j] = value
            # own block: pose on the arc, the motion's end velocity as the measured (v, w), the
            # goal point
            gx = goal_d * math.cos(bearing) - dx
            gy = goal_d * math.sin(bearing) - dy
            gx, gy = c * gx + s * gy, -s * gx + c * gy
            out[b, a, n] = x + dx * cy - dy * sy
            out[b, a, n + 1] = y + dx * sy + dy * cy
            out[b, a, n + 2] = math.atan2(math.sin(yaw + turn), math.cos(yaw + turn))
            out[b, a, n + 3] = v_next
            out[b, a, n + 4] = w_next
            out[b, a, n + 5] = math.hypot(gx, gy)
            out[b, a, n + 6] = math.atan2(gy, gx)
            # movers at their observed velocity, seen from the new pose; empty slots stay zero
            for k in range(n + _OWN, obs.shape[1], features):
                px, py, ux, uy = obs[b, k], obs[b, k + 1], obs[b, k + 2], obs[b, k + 3]
                if abs(px) + abs(py) + abs(ux) + abs(uy) == 0.0:
                    out[b, a, k : k + features] = 0.0
                    continue
                ux += v  # the mover's velocity in the old robot frame
                qx, qy = px + ux * dt_s - dx, py + uy * dt_s - dy
                out[b, a, k] = c * qx + s * qy
                out[b, a, k + 1] = -s * qx + c * qy
                out[b, a, k + 2] = c * ux + s * uy - v_next
                out[b, a, k + 3] = -s * ux + c * uy


# numba keys this module's cache on this file alone; the kernels call robots' drive step and
# the pose's arc step too
for _kernel in (driven_arcs, predict_kernel):
    _jit.key_cache(
        _kernel, {Path(__file__), *(Path(str(m.__file__)) for m in (robots._kernel, _robot))}
    )


class LookaheadQNetwork(QNetwork):  # type: ignore[misc]
    """:math:`Q(s, a) = V(f(s, a))`: the value head on each action's predicted observation.

    ``lookahead`` holds :class:`RaceLookahead`'s fields (a plain mapping, saved in the zip).
    """

    def __init__(self, *args: Any, lookahead: dict[str, Any], **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lookahead = dict(lookahead)
        fields = {k: tuple(v) if isinstance(v, list) else v for k, v in self.lookahead.items()}
        self.model = RaceLookahead(**cast(dict[str, Any], fields))
        if len(self.model.v_mps) != int(self.action_space.n):
            raise Sim2RealValueError(
                f"policy 'sarl-lookahead' has {len(self.model.v_mps)} look-ahead commands for "
                f"{self.action_space.n} actions; its grid must be the discrete_actions grid"
            )
        self.q_net = nn.Sequential(
            *create_mlp(self.features_dim, 1, self.net_arch, self.activation_fn)
        )

    def forward(self, obs: Any) -> torch.Tensor:
        """Q-values (batch, actions): the value of each action's predicted observation."""
        flat = preprocess_obs(obs, self.observation_space, normalize_images=self.normalize_images)
        nxt = self.model.predict(cast(torch.Tensor, flat).float())
        b, n_act, d = nxt.shape
        values = self.q_net(self.features_extractor(nxt.reshape(b * n_act, d)))
        return values.reshape(b, n_act)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "lookahead": self.lookahead}


class LookaheadDQNPolicy(DQNPolicy):  # type: ignore[misc]
    """SB3's DQN policy whose Q-network is :class:`LookaheadQNetwork`.

    Parameters
    ----------
    *args, **kwargs
        Those of ``DQNPolicy``.
    lookahead : dict
        :class:`RaceLookahead`'s fields (``dataclasses.asdict`` of :func:`race_lookahead`).
    """

    def __init__(self, *args: Any, lookahead: dict[str, Any], **kwargs: Any) -> None:
        self.lookahead = dict(lookahead)
        super().__init__(*args, **kwargs)

    def set_training_mode(self, mode: bool) -> None:
        """SB3's train/eval switch, skipped when the modules are in ``mode`` already: DQN
        calls it at every step and every update, and each call walks every module."""
        if mode != self.training or mode != self.q_net.training:
            super().set_training_mode(mode)

    def make_q_net(self) -> LookaheadQNetwork:
        net_args = self._update_features_extractor(self.net_args, features_extractor=None)
        return LookaheadQNetwork(**net_args, lookahead=self.lookahead).to(self.device)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "lookahead": self.lookahead}


def lookahead_kwargs(model: RaceLookahead) -> dict[str, Any]:
    """``model`` as the plain ``lookahead`` policy keyword (lists, floats)."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(model).items()}
