"""The training workflow: train a policy from one YAML file and evaluate it.

- :mod:`~sim2real.training.train` reads a training config, builds the env and its randomizer
  stack and runs stable-baselines3;
- :mod:`~sim2real.training._rllib` runs the same env construction with RLlib's PPO;
- :mod:`~sim2real.training.evaluation` loads trained policies and evaluates them (success,
  robustness, Wilson intervals).

May import :mod:`randomizers`, :mod:`robots`, :mod:`sysid` and :mod:`sim2real.envs`; the
optional extras (torch, stable-baselines3, Ray) only inside the functions that need them.
"""
