"""The policy network's observation encoder (PyTorch; only ``citygen train`` imports it).

:class:`MapEncoder` is a Stable-Baselines3 features extractor: every image-like key (a
``(C, H, W)`` Box, such as the navigation observation's ``local_map``) goes through a small
CNN (:attr:`TrainConfig.conv <citygen.runner.learn.config.TrainConfig.conv>` layers of
``(channels, kernel, stride)``, ReLU, no padding, then one linear layer of
:attr:`TrainConfig.map_features` units with ReLU); every other key is flattened; the results
are concatenated in the observation space's key order, as SB3's ``CombinedExtractor`` does.
The actor and critic MLPs read that vector. :mod:`citygen.runner.learn.export` writes the
CNN's weights beside the MLP's and evaluates them with numpy.

A 2,048-input map fed straight into a 128-unit MLP learns slowly (each weight sees one cell:
an obstacle one cell to the left is a new problem); convolutions share what they learn over
the window.
"""

from __future__ import annotations

import gymnasium
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor


def is_map(space: gymnasium.spaces.Space) -> bool:
    """Whether a key's space is image-like (``(C, H, W)``), so the CNN encodes it."""
    return isinstance(space, gymnasium.spaces.Box) and len(space.shape) == 3


class MapEncoder(BaseFeaturesExtractor):
    """CNN for image-like keys, flatten for the rest (see the module docstring)."""

    def __init__(
        self,
        observation_space: gymnasium.spaces.Dict,
        conv: tuple[tuple[int, int, int], ...] = ((16, 5, 2), (32, 3, 2)),
        map_features: int = 128,
    ):
        encoders: dict[str, torch.nn.Module] = {}
        width = 0
        for key, space in observation_space.spaces.items():
            if is_map(space):
                layers: list[torch.nn.Module] = []
                channels = space.shape[0]
                for out, kernel, stride in conv:
                    layers += [torch.nn.Conv2d(channels, out, kernel, stride), torch.nn.ReLU()]
                    channels = out
                layers.append(torch.nn.Flatten())
                with torch.no_grad():
                    n = torch.nn.Sequential(*layers)(torch.zeros(1, *space.shape)).shape[1]
                layers += [torch.nn.Linear(n, map_features), torch.nn.ReLU()]
                encoders[key] = torch.nn.Sequential(*layers)
                width += map_features
            else:
                encoders[key] = torch.nn.Flatten()
                width += int(torch.tensor(space.shape).prod())
        super().__init__(observation_space, features_dim=width)
        self.encoders = torch.nn.ModuleDict(encoders)

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        return torch.cat([encoder(observations[key]) for key, encoder in self.encoders.items()], dim=1)
