"""The training workflow: train a policy from one YAML file and evaluate it.

- :mod:`~sim2real.training.config` reads and checks a training config (:class:`TrainConfig`);
- :mod:`~sim2real.training.environment` builds the env a policy trains and is evaluated on
  (registered env, randomizer stack, action grid, space scaling);
- :mod:`~sim2real.training.evaluation` loads trained policies and evaluates them (success,
  robustness, Wilson intervals);
- :mod:`~sim2real.training._rllib` runs the same env construction with RLlib's PPO;
- :mod:`~sim2real.training.train` runs stable-baselines3 (or RLlib) and writes the outputs.

The modules import in that order (config, environment, _rllib, evaluation, train), never back.
May import :mod:`randomizers`, :mod:`robots`, :mod:`sysid`, :mod:`sim2real.envs` and
:mod:`sim2real.cluster`; the optional extras (torch, stable-baselines3, Ray) only inside the
functions that need them.
"""
