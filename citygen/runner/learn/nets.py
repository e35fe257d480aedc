"""The policy network's observation encoder (PyTorch; only ``citygen train`` imports it).

:class:`MapEncoder` is a Stable-Baselines3 features extractor: every image-like key (a
``(C, H, W)`` Box, such as the navigation observation's ``local_map``) goes through a small
CNN (:attr:`TrainConfig.conv <citygen.runner.learn.config.TrainConfig.conv>` layers of
``(channels, kernel, stride)``, ReLU, no padding, then one linear layer of
:attr:`TrainConfig.map_features` units with ReLU); every other key is flattened; the results
are concatenated in the observation space's key order, as SB3's ``CombinedExtractor`` does.
``stack`` groups image-like keys of the same height and width into one CNN's input channels
(:attr:`TrainConfig.stack <citygen.runner.learn.config.TrainConfig.stack>`): the group is
encoded where its first key stands, named by it, and its other keys add no features of their
own. A layer the robot reads beside the local map (``local_map_crossable``) then shares its
filters, instead of bringing a second CNN and another ``map_features`` inputs to train.
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
        stack: tuple[tuple[str, ...], ...] = (),
    ):
        spaces = observation_space.spaces
        stacks: dict[str, tuple[str, ...]] = {}  # each CNN's input keys, by the first
        stacked = set()
        for group in map(tuple, stack):
            if not all(k in spaces and is_map(spaces[k]) for k in group) or (
                len({spaces[k].shape[1:] for k in group}) != 1
            ):
                raise ValueError(f"stack: {list(group)} must name image-like keys of one height and width")
            stacks[group[0]] = group
            stacked.update(group[1:])
        encoders: dict[str, torch.nn.Module] = {}
        width = 0
        for key, space in spaces.items():
            if key in stacked:
                continue
            if is_map(space):
                group = stacks.setdefault(key, (key,))
                layers: list[torch.nn.Module] = []
                channels = sum(spaces[k].shape[0] for k in group)
                probe = torch.zeros(1, channels, *space.shape[1:])
                for out, kernel, stride in conv:
                    layers += [torch.nn.Conv2d(channels, out, kernel, stride), torch.nn.ReLU()]
                    channels = out
                layers.append(torch.nn.Flatten())
                with torch.no_grad():
                    n = torch.nn.Sequential(*layers)(probe).shape[1]
                layers += [torch.nn.Linear(n, map_features), torch.nn.ReLU()]
                encoders[key] = torch.nn.Sequential(*layers)
                width += map_features
            else:
                encoders[key] = torch.nn.Flatten()
                width += int(torch.tensor(space.shape).prod())
        super().__init__(observation_space, features_dim=width)
        self.encoders = torch.nn.ModuleDict(encoders)
        self.stacks = stacks

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        parts = [encoder(self._input(observations, key)) for key, encoder in self.encoders.items()]
        return torch.cat(parts, dim=1)

    def _input(self, observations: dict[str, torch.Tensor], key: str) -> torch.Tensor:
        group = self.stacks.get(key, (key,))
        if len(group) == 1:
            return observations[key]
        return torch.cat([observations[k] for k in group], dim=1)
