r"""A non-learned controller for ``CarCrossing-v0``: change lane early, wait, pass.

It sees only the env's 14-value observation (and remembers its own commands, which start at
the env's 0.6 m/s and 0 degrees):

1. from the start it steers into the adjacent lane (lateral controller on the observed
   y and heading: desired heading :math:`\mathrm{clip}(k_y (y^* - y), \pm 0.6)` rad, desired
   steering :math:`\mathrm{clip}(k_\theta (\theta^* - \theta), \pm 30°)`) at a moderate speed;
2. it stops beside the obstacle, before the pedestrian's crossing line (at x = 1.15 m: the
   obstacle's near face is at least 1.2 m and the pedestrian at least 1.7 m ahead of the start
   in every episode), braking on :math:`v^* = \min(v_{cruise}, \sqrt{2 a (x_{stop} - x)})`;
3. it waits until it has seen the pedestrian standing still for three steps (its observed
   distance unchanged: the pedestrian has finished crossing and stands at the road side);
4. it drives to the goal line in the adjacent lane.

Each step it issues one of the four discrete actions: a brake step when the speed command
is more than 0.05 m/s above the target speed, else a steering step when the steering command
is more than 2.5 degrees off the desired one, else the speed step towards the target speed
(braking when at or above it).

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> from sim2real.envs.car_baseline import CarCrossingBaseline
>>> env = gym.make("sim2real/CarCrossing-v0")
>>> ctrl = CarCrossingBaseline()
>>> obs, _ = env.reset(seed=0)
>>> ctrl.reset()
>>> int(ctrl.act(obs)) in range(4)
True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sim2real.envs.car_crossing import (
    DETECT_RANGE_M,
    GOAL_X_M,
    OWN_LANE_Y_M,
    ROAD_HALF_WIDTH_M,
    SPEED_STEP_DOWN_MPS,
    SPEED_STEP_UP_MPS,
    START_SPEED_MPS,
    STEER_STEP_RAD,
)

__all__ = ["CarCrossingBaseline"]

_MAX_STEER_RAD = math.radians(30.0)


class CarCrossingBaseline:
    """Rule-based controller of ``CarCrossing-v0`` (see the module docstring).

    Parameters
    ----------
    cruise_mps : float
        Speed while changing lane and approaching the stop.
    final_mps : float
        Speed after the pedestrian has crossed.
    stop_x_m : float
        Where it waits, m from the start.
    brake_mps2 : float
        Planned deceleration for the stop, m/s^2.
    """

    def __init__(
        self,
        *,
        cruise_mps: float = 0.45,
        final_mps: float = 0.6,
        stop_x_m: float = 1.15,
        brake_mps2: float = 0.5,
    ) -> None:
        self.cruise_mps = cruise_mps
        self.final_mps = final_mps
        self.stop_x_m = stop_x_m
        self.brake_mps2 = brake_mps2
        self.reset()

    def reset(self) -> None:
        """Start of an episode: the env's initial commands, nothing seen yet."""
        self.cmd_speed = START_SPEED_MPS
        self.cmd_steer = 0.0
        self._last_ped_d = math.nan
        self._still_steps = 0
        self.go = False

    @classmethod
    def for_env(cls, env: Any) -> CarCrossingBaseline:
        """The default controller (the env argument mirrors the other baselines)."""
        del env
        return cls()

    def _update_pedestrian(self, obs: Any) -> None:
        seen = obs[12] > 0.5
        d = float(obs[9]) * DETECT_RANGE_M
        if seen and abs(d - self._last_ped_d) < 1e-4:
            self._still_steps += 1
        else:
            self._still_steps = 0
        self._last_ped_d = d if seen else math.nan
        if self._still_steps >= 3:
            self.go = True

    def act(self, obs: Any) -> int:
        """The discrete action for an observation."""
        o = np.asarray(obs, dtype=np.float64)
        x, y = o[0] * GOAL_X_M, o[1] * ROAD_HALF_WIDTH_M
        heading = o[13] * math.pi
        self._update_pedestrian(o)
        y_target = -OWN_LANE_Y_M
        heading_des = float(np.clip(2.5 * (y_target - y), -0.6, 0.6))
        steer_des = float(np.clip(2.0 * (heading_des - heading), -_MAX_STEER_RAD, _MAX_STEER_RAD))
        if self.go:
            v_target = self.final_mps
        else:
            room = max(self.stop_x_m - x, 0.0)
            v_target = min(self.cruise_mps, math.sqrt(2.0 * self.brake_mps2 * room))
        if self.cmd_speed > v_target + 0.05:  # braking comes before steering
            self.cmd_speed = max(self.cmd_speed - SPEED_STEP_DOWN_MPS, 0.0)
            return 1
        tol = 0.5 * STEER_STEP_RAD
        if self.cmd_steer < steer_des - tol and self.cmd_steer < _MAX_STEER_RAD - 1e-9:
            self.cmd_steer += STEER_STEP_RAD
            return 2
        if self.cmd_steer > steer_des + tol and self.cmd_steer > -_MAX_STEER_RAD + 1e-9:
            self.cmd_steer -= STEER_STEP_RAD
            return 3
        if self.cmd_speed + SPEED_STEP_UP_MPS <= v_target + 0.5 * SPEED_STEP_UP_MPS and (
            self.cmd_speed < v_target
        ):
            self.cmd_speed += SPEED_STEP_UP_MPS
            return 0
        self.cmd_speed = max(self.cmd_speed - SPEED_STEP_DOWN_MPS, 0.0)
        return 1
