"""An RLlib ``RLModule`` for the robots' observations: a CNN on the map image, the rest as is.

:class:`ExplorationModule` reads one robot's observation in the normalised
format (:mod:`envs.observations`) as the environment gives it, without
flattening it first:

1. ``map`` ``(3, size, size)`` uint8, the free, occupied and unknown channels
   of the map window, scaled to ``[0, 1]``, goes through a convolutional
   encoder (by default the "Nature" CNN of Mnih et al. 2015, as in
   Stable-Baselines3's ``MultiInputPolicy``) to ``map_features`` numbers;
2. ``scan`` (beams,) and ``pose`` (4,), already in ``[0, 1]`` and ``[-1, 1]``,
   are appended to them;
3. two heads of ``head_hiddens`` tanh layers read these features: the policy
   head gives the mean of a diagonal Gaussian over the ``(linear, angular)``
   action, whose log standard deviation is a learnt parameter independent of
   the observation (as Stable-Baselines3's PPO), and the value head gives the
   state value. The features are the ``EMBEDDINGS`` RLlib's PPO hands back to
   :meth:`~ExplorationModule.compute_values`, so a training pass encodes once.

``model_config`` (``RLModuleSpec(model_config=...)``) may override any entry
of :data:`DEFAULT_MODEL_CONFIG` (:func:`model_options`). Policy and value
share the encoder whatever RLlib's ``vf_share_layers`` says.

Importing this module needs ``ray[rllib]`` and torch (the ``rllib`` extra).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, fields
from typing import Any

import torch
from gymnasium import spaces
from ray.rllib.core.columns import Columns
from ray.rllib.core.rl_module.apis import ValueFunctionAPI
from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
from ray.rllib.core.rl_module.torch import TorchRLModule
from torch import nn

from envs.observations import CHANNEL_ON

DEFAULT_MODEL_CONFIG: dict[str, Any] = {
    "conv_filters": [(32, 8, 4), (64, 4, 2), (64, 3, 1)],
    "map_features": 256,
    "head_hiddens": [64, 64],
    "initial_log_std": 0.0,
}
"""The network's shape: ``conv_filters`` as ``(channels, kernel, stride)`` per layer (the
Nature CNN), the size of the map's encoding, the hidden layers of each head, and the
log standard deviation of the actions at the start (0: one, the action range's half-width)."""
POLICY_HEAD_GAIN = 0.01
"""Scale of the policy head's last layer at initialisation: the first actions' means lie
near 0, so that exploration starts from the Gaussian alone (as Stable-Baselines3 does)."""


def model_options(model_config: Mapping[str, Any] | DefaultModelConfig | None) -> dict[str, Any]:
    """:data:`DEFAULT_MODEL_CONFIG` updated with ``model_config``'s entries for it.

    The algorithm adds its own generic entries (RLlib's ``DefaultModelConfig``,
    such as PPO's ``vf_share_layers``); they are ignored, and so is a None
    value. Any other key is refused, so that a misspelt option does not pass
    unnoticed.
    """
    given = dict(
        asdict(model_config) if isinstance(model_config, DefaultModelConfig) else model_config or {}
    )
    unknown = set(given) - set(DEFAULT_MODEL_CONFIG) - {f.name for f in fields(DefaultModelConfig)}
    if unknown:
        raise ValueError(
            f"unknown model_config keys {sorted(unknown)}; this module reads "
            f"{sorted(DEFAULT_MODEL_CONFIG)}"
        )
    return {
        key: default if given.get(key) is None else given[key]
        for key, default in DEFAULT_MODEL_CONFIG.items()
    }


def _head(inputs: int, hiddens: list[int], outputs: int, *, gain: float) -> nn.Sequential:
    """A tanh MLP, orthogonally initialised; the last layer scaled by ``gain``."""
    layers: list[nn.Module] = []
    for width in hiddens:
        layer = nn.Linear(inputs, width)
        nn.init.orthogonal_(layer.weight, gain=math.sqrt(2))
        nn.init.zeros_(layer.bias)
        layers += [layer, nn.Tanh()]
        inputs = width
    last = nn.Linear(inputs, outputs)
    nn.init.orthogonal_(last.weight, gain=gain)
    nn.init.zeros_(last.bias)
    return nn.Sequential(*layers, last)


class ExplorationModule(TorchRLModule, ValueFunctionAPI):
    """One robot's policy and value function (module docstring)."""

    def setup(self) -> None:
        """Build the encoder and heads for this module's observation and action spaces."""
        options = model_options(self.model_config)
        space = self.observation_space
        image = space.spaces.get("map") if isinstance(space, spaces.Dict) else None
        if not (isinstance(space, spaces.Dict) and isinstance(image, spaces.Box)) or (
            len(image.shape) != 3
        ):
            raise ValueError(
                "ExplorationModule reads the normalised observation (a Dict with a "
                f"(3, size, size) map image), got {space}; make the environment with "
                'observation_format="normalised"'
            )
        if not (isinstance(self.action_space, spaces.Box) and len(self.action_space.shape) == 1):
            raise ValueError(f"ExplorationModule needs a 1-D Box action, got {self.action_space}")
        channels, rows, cols = image.shape
        scan, pose = space["scan"], space["pose"]
        assert scan.shape is not None and pose.shape is not None  # Boxes have shapes
        layers: list[nn.Module] = []
        for width, kernel, stride in options["conv_filters"]:
            layers += [nn.Conv2d(channels, width, kernel, stride), nn.ReLU()]
            channels = width
        convolutions = nn.Sequential(*layers, nn.Flatten())
        with torch.no_grad():
            flat = convolutions(torch.zeros(1, image.shape[0], rows, cols)).shape[1]
        self.map_encoder = nn.Sequential(
            convolutions, nn.Linear(flat, options["map_features"]), nn.ReLU()
        )
        others = math.prod(scan.shape) + math.prod(pose.shape)
        features = options["map_features"] + others
        actions = self.action_space.shape[0]
        hiddens = list(options["head_hiddens"])
        self.policy_head = _head(features, hiddens, actions, gain=POLICY_HEAD_GAIN)
        self.value_head = _head(features, hiddens, 1, gain=1.0)
        self.log_std = nn.Parameter(torch.full((actions,), float(options["initial_log_std"])))

    def encode(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        """The features of a batch of observations: ``(B, map_features + beams + 4)``."""
        image = observations["map"].float() / CHANNEL_ON
        return torch.cat(
            [
                self.map_encoder(image),
                observations["scan"].float().flatten(1),
                observations["pose"].float().flatten(1),
            ],
            dim=-1,
        )

    def _distribution_inputs(self, features: torch.Tensor) -> torch.Tensor:
        """Means and log standard deviations, as RLlib's ``TorchDiagGaussian`` reads them."""
        mean = self.policy_head(features)
        return torch.cat([mean, self.log_std.expand_as(mean)], dim=-1)

    def _forward(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        features = self.encode(batch[Columns.OBS])
        return {Columns.ACTION_DIST_INPUTS: self._distribution_inputs(features)}

    def _forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        features = self.encode(batch[Columns.OBS])
        return {
            Columns.ACTION_DIST_INPUTS: self._distribution_inputs(features),
            Columns.EMBEDDINGS: features,
        }

    def compute_values(
        self, batch: dict[str, Any], embeddings: torch.Tensor | None = None
    ) -> torch.Tensor:
        """State values ``(B,)``, from ``embeddings`` when a training pass gives them."""
        features = self.encode(batch[Columns.OBS]) if embeddings is None else embeddings
        return self.value_head(features).squeeze(-1)
