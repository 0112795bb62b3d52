"""A small encoder per range sensor as a stable-baselines3 features extractor (``[train]`` extra).

SB3's ``CombinedExtractor`` flattens every entry of a Dict observation into one vector, so in
CrowdNav-v0 the 2 goal values are 2 of over a thousand inputs beside the lidar scan and the
depth image, and PPO learns to stand still before it learns to aim
(``benchmarks/crowdnav_aim.py``). Here every entry larger than ``pass_through`` values (the
sensors) goes through its own ``Linear`` + ``tanh`` layer to ``width`` features, and the small
entries (goal, velocity) reach the policy as they are.

Examples
--------
>>> import numpy as np, torch
>>> from gymnasium import spaces
>>> space = spaces.Dict({"goal": spaces.Box(-1, 1, (2,)), "lidar": spaces.Box(-1, 1, (640,))})
>>> net = SensorEncoderExtractor(space, width=8)
>>> net.features_dim, net({"goal": torch.ones(3, 2), "lidar": torch.zeros(3, 640)}).shape
(10, torch.Size([3, 10]))
"""

from __future__ import annotations

import math
from typing import Any

import torch
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

__all__ = ["SensorEncoderExtractor"]


class SensorEncoderExtractor(BaseFeaturesExtractor):  # type: ignore[misc]
    """Small Dict entries as they are, each large one encoded to ``width`` features.

    Parameters
    ----------
    observation_space : gymnasium.spaces.Dict
        A Dict of Boxes.
    width : int
        Features per encoded entry.
    pass_through : int
        Entries with at most this many values are passed through unencoded.
    """

    def __init__(
        self, observation_space: spaces.Space[Any], *, width: int = 8, pass_through: int = 8
    ) -> None:
        assert isinstance(observation_space, spaces.Dict)  # checked by the training config
        sizes = {k: math.prod(s.shape or (1,)) for k, s in observation_space.spaces.items()}
        self.small = [k for k, n in sizes.items() if n <= pass_through]
        self.large = [k for k, n in sizes.items() if n > pass_through]
        super().__init__(
            observation_space,
            features_dim=sum(sizes[k] for k in self.small) + width * len(self.large),
        )
        self.encoders = nn.ModuleDict(
            {k: nn.Sequential(nn.Linear(sizes[k], width), nn.Tanh()) for k in self.large}
        )

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        """The small entries flattened, then each large entry's ``width`` features."""
        parts = [observations[k].flatten(1) for k in self.small]
        parts += [self.encoders[k](observations[k].flatten(1)) for k in self.large]
        return torch.cat(parts, dim=1)
