"""Reference training envs from the literature, registered with gymnasium on import.

- ``sim2real/CrowdNav-v0`` (:class:`CrowdNavEnv`): a TurtleBot 2 with a 2-D lidar and a depth
  camera among pedestrians whose walking speed follows Liang et al. (2020), eq. (1); three scenario
  families and a complexity factor.
- ``sim2real/RandomMap-v0`` (:class:`RandomMapEnv`): a TurtleBot 3 Burger crossing random maps
  of walls and cylinders (Yang et al., Table I presets).
- ``sim2real/CarCrossing-v0`` (:class:`CarCrossingEnv`): a small Ackermann car passes an
  obstacle while an occluded pedestrian crosses the adjacent lane (Trararak et al.).
- ``sim2real/Race-v0`` (:class:`RaceEnv`) and :func:`race_parallel_env` (PettingZoo): TurtleBot
  3 Burgers race ORCA opponents on walled tracks (Pozo Ruiz 2024).
- ``sim2real/MujocoNav-v0`` (:mod:`sim2real.envs.mujoco_nav`, the [mujoco] extra): the
  exported MuJoCo robot drives to a goal; a ``DynamicsRandomizer`` draws each episode's robot
  into its ``MjModel``.

They take ``dynamics="reduced"`` (the identified drive model in numba, pose integrated
kinematically, exact 2-D world) or ``dynamics="pybullet"`` (the rigid-body robot of
:mod:`robots`), expose ``control_dt`` and the drive-parameter protocol, and CrowdNav the
camera-pose protocol of ``docs/ARCHITECTURE.md``. RandomMap-v0, CrowdNav-v0 and Race-v0 also
take ``dynamics="plant"``: a foreign base (:mod:`sim2real.plants.closed_loop`), one session
per episode from ``plant_sessions=``, to evaluate a policy on, never to train on.

May import :mod:`robots`, :mod:`sim2real.plants` and :mod:`sim2real.mujoco`.

Examples
--------
>>> import gymnasium as gym
>>> import sim2real.envs
>>> env = gym.make("sim2real/RandomMap-v0", preset="TEST2", dynamics="reduced")
>>> obs, info = env.reset(seed=1)
>>> env.unwrapped.control_dt
0.1
"""

from __future__ import annotations

import gymnasium as gym

from sim2real.envs.baselines import DWAController, EvalSummary, evaluate
from sim2real.envs.car_crossing import CarCrossingEnv, CarCrossingReward
from sim2real.envs.crowd_nav import SCENARIOS, CrowdNavEnv, CrowdNavReward
from sim2real.envs.maps import PAPER_RHO_OBS, PRESETS, MapConfig, generate_map
from sim2real.envs.metrics import EpisodeMetrics
from sim2real.envs.orca import OrcaAgents, OrcaConfig, orca_velocities
from sim2real.envs.race import RaceEnv, RaceParallelEnv, RaceReward, race_parallel_env
from sim2real.envs.random_map import RandomMapEnv, RandomMapReward
from sim2real.envs.vector import CrowdNavVectorEnv, NavVectorEnv, RandomMapVectorEnv

__all__ = [
    "ENV_IDS",
    "PAPER_RHO_OBS",
    "PRESETS",
    "SCENARIOS",
    "CarCrossingEnv",
    "CarCrossingReward",
    "CrowdNavEnv",
    "CrowdNavReward",
    "CrowdNavVectorEnv",
    "DWAController",
    "EpisodeMetrics",
    "EvalSummary",
    "MapConfig",
    "NavVectorEnv",
    "OrcaAgents",
    "OrcaConfig",
    "RaceEnv",
    "RaceParallelEnv",
    "RaceReward",
    "RandomMapEnv",
    "RandomMapReward",
    "RandomMapVectorEnv",
    "evaluate",
    "generate_map",
    "orca_velocities",
    "race_parallel_env",
]

#: The registered env ids.
ENV_IDS = (
    "sim2real/CrowdNav-v0",
    "sim2real/RandomMap-v0",
    "sim2real/CarCrossing-v0",
    "sim2real/Race-v0",
    "sim2real/MujocoNav-v0",
)

# The envs end episodes themselves (metrics need the outcome), so no TimeLimit wrapper.
if "sim2real/CrowdNav-v0" not in gym.registry:
    gym.register(
        id="sim2real/CrowdNav-v0",
        entry_point="sim2real.envs.crowd_nav:CrowdNavEnv",
        vector_entry_point="sim2real.envs.vector:CrowdNavVectorEnv",
    )
if "sim2real/RandomMap-v0" not in gym.registry:
    gym.register(
        id="sim2real/RandomMap-v0",
        entry_point="sim2real.envs.random_map:RandomMapEnv",
        vector_entry_point="sim2real.envs.vector:RandomMapVectorEnv",
    )
if "sim2real/Race-v0" not in gym.registry:
    gym.register(id="sim2real/Race-v0", entry_point="sim2real.envs.race:RaceEnv")
if "sim2real/MujocoNav-v0" not in gym.registry:  # the [mujoco] extra
    gym.register(id="sim2real/MujocoNav-v0", entry_point="sim2real.envs.mujoco_nav:MujocoNavEnv")
if "sim2real/CarCrossing-v0" not in gym.registry:
    gym.register(
        id="sim2real/CarCrossing-v0", entry_point="sim2real.envs.car_crossing:CarCrossingEnv"
    )
