r"""SARL*'s crowd-aware network as a stable-baselines3 features extractor (needs the ``[train]`` extra).

Chen et al. (2019, "Crowd-robot interaction: crowd-aware robot navigation with
attention-based deep reinforcement learning", ICRA) value each human by a pairwise
robot-human embedding and pool the humans with a learned attention; Li et al. (2019,
"Role of human-robot interaction in crowd navigation", SARL*) keep that network and steer it
towards a local goal on a global plan. Here, for an observation with ``K`` neighbour slots of
``F`` values (:func:`sim2real.training.environment.neighbour_slots`):

.. math::

    r = \phi_s(s), \quad e_i = \psi_e(r, w_i, |p_i|), \quad h_i = \psi_h(e_i), \quad
    \alpha_i = \operatorname{softmax}_i \psi_\alpha(e_i, \bar e), \quad
    f = [r, \textstyle\sum_i \alpha_i h_i]

with :math:`s` the robot's own observation (everything but the neighbour slots), :math:`w_i`
neighbour i's row (relative position :math:`p_i` and velocity, robot frame), :math:`\bar e`
the mean embedding of the present neighbours (SARL's global state) and the softmax taken over
the present ones only (an all-zero row is an empty slot). Every weight is shared across
neighbours, so the network takes any number of them and their order does not matter. SB3's
heads read :math:`f`: with DQN it is SARL's value network over a discrete (v, w) action set,
learned as :math:`Q(s, a)`; SARL's :math:`V` of a one-step look-ahead needs a model of the
next observation, which :mod:`sim2real.training._lookahead` gives for Race-v0.

Examples
--------
>>> import numpy as np, torch
>>> from gymnasium import spaces
>>> space = spaces.Box(-10.0, 10.0, (6 + 3 * 4,), np.float32)
>>> net = SarlExtractor(space, neighbours=3, neighbour_features=4)
>>> net(torch.zeros(2, 18)).shape
torch.Size([2, 128])
"""

from __future__ import annotations

import itertools
import math
from typing import Any, cast

import torch
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

__all__ = ["NEIGHBOURS_KEY", "SarlExtractor"]

#: The Dict observation entry holding the neighbour slots.
NEIGHBOURS_KEY = "neighbours"


def _mlp(*sizes: int) -> nn.Sequential:
    layers: list[nn.Module] = []
    for a, b in itertools.pairwise(sizes):
        layers += [nn.Linear(a, b), nn.ReLU()]
    return nn.Sequential(*layers)


def _split_linear(
    layer: nn.Linear, shared: torch.Tensor, slots: torch.Tensor, *, shared_first: bool = True
) -> torch.Tensor:
    """``layer([shared, slot])`` (or ``[slot, shared]``) for every slot: (B, S), (B, K, F) -> (B, K, out)."""
    n = shared.shape[-1]
    cut = slice(None, n) if shared_first else slice(layer.in_features - n, None)
    rest = slice(n, None) if shared_first else slice(None, layer.in_features - n)
    own = nn.functional.linear(shared, layer.weight[:, cut], layer.bias).unsqueeze(1)
    return own + nn.functional.linear(slots, layer.weight[:, rest])


class SarlExtractor(BaseFeaturesExtractor):  # type: ignore[misc]
    """Robot embedding plus attention-pooled robot-human embeddings (see the module docstring).

    Parameters
    ----------
    observation_space : gymnasium.spaces.Box or Dict
        A Box whose last ``neighbours * neighbour_features`` values are the neighbour slots, or
        a Dict with a ``"neighbours"`` entry (the other entries, flattened, are the robot's).
    neighbours, neighbour_features : int
        Slots K and values per slot F.
    robot_dim, pair_dim : int
        Widths of :math:`\\phi_s` and of the pairwise embedding (SARL: 150-100 and 100-50).
    """

    def __init__(
        self,
        observation_space: spaces.Space[Any],
        *,
        neighbours: int,
        neighbour_features: int,
        robot_dim: int = 64,
        pair_dim: int = 64,
    ) -> None:
        super().__init__(observation_space, features_dim=robot_dim + pair_dim)
        self.k, self.f = int(neighbours), int(neighbour_features)
        if isinstance(observation_space, spaces.Dict):
            self.keys = [key for key in observation_space.spaces if key != NEIGHBOURS_KEY]
            sizes = [observation_space.spaces[key].shape for key in self.keys]
            own = sum(math.prod(s or (1,)) for s in sizes)
        else:
            self.keys = []
            own = math.prod(observation_space.shape or (1,)) - self.k * self.f
        self.robot = _mlp(own, robot_dim)
        self.pair = _mlp(robot_dim + self.f + 1, 2 * pair_dim, pair_dim)
        self.hidden = _mlp(pair_dim, pair_dim)
        self.score = nn.Sequential(_mlp(2 * pair_dim, pair_dim), nn.Linear(pair_dim, 1))

    def _split(self, obs: Any) -> tuple[torch.Tensor, torch.Tensor]:
        if self.keys:
            own = torch.cat([obs[key].flatten(1) for key in self.keys], dim=1)
            slots = obs[NEIGHBOURS_KEY].flatten(1)
        else:
            flat = obs.flatten(1)
            own, slots = flat[:, : flat.shape[1] - self.k * self.f], flat[:, -self.k * self.f :]
        return own, slots.reshape(slots.shape[0], -1, self.f)

    def forward(self, obs: Any) -> torch.Tensor:
        """Features (batch, robot_dim + pair_dim) of a batch of observations."""
        own, rows = self._split(obs)
        r = self.robot(own)
        present = (rows.abs().sum(dim=-1) > 0).unsqueeze(-1).to(rows.dtype)  # (B, K, 1)
        dist = torch.linalg.vector_norm(rows[..., :2], dim=-1, keepdim=True)
        # the first layers of psi_e and psi_alpha on concatenated inputs, split by part: the
        # robot's and the mean's share is computed once per observation, not once per slot
        e = self.pair[2:](
            torch.relu(_split_linear(cast(nn.Linear, self.pair[0]), r, torch.cat([rows, dist], -1)))
        )
        mean = (e * present).sum(dim=1, keepdim=True) / present.sum(dim=1, keepdim=True).clamp(1)
        logits = self.score[1](
            torch.relu(
                _split_linear(
                    cast(nn.Linear, cast(nn.Sequential, self.score[0])[0]),
                    mean.squeeze(1),
                    e,
                    shared_first=False,
                )
            )
        )
        logits = logits.masked_fill(present == 0, -1e9)
        alpha = torch.softmax(logits, dim=1) * present  # no neighbour: all weights 0
        pooled = (alpha * self.hidden(e)).sum(dim=1)
        return torch.cat([r, pooled], dim=-1)
