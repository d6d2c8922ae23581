"""``CompactExtractor``: FireCast's compact CNN (firecast-rl's ``compact`` policy) as a
Stable-Baselines3 features extractor, so SB3 users train on the helitack observation with the
network FireCast's own trainer uses.

Layer for layer the Rust extractor with its defaults (``view: map``, frame stack, no batch
normalisation; ``crates/firecast-rl/src/policy.rs``), parameters named as its checkpoints name
them under ``features_extractor.``:

- input: the 4 frames of cell codes and a helicopter channel (1 on the helicopter's cell), all
  divided by 9 (the largest code), average-pooled 2×;
- ``cnn.branch_a``: 3×3 conv → 16, ReLU, 2× max pool, 3×3 conv → 32, ReLU, 2× max pool;
  ``cnn.branch_b``: 5×5 stride-2 conv → 8, ReLU, 5×5 stride-2 conv → 16, ReLU (cut to branch
  a's size); ``cnn.branch_c``: 11×11 stride-4 conv → 8, ReLU, 7×7 stride-2 conv → 16, ReLU,
  bilinear upsampling to branch a's size;
- ``cnn.attention`` over the 64 concatenated channels: 1×1 conv → 32, ReLU, 1×1 conv → 1,
  sigmoid; ``f · attention + f``;
- ``reduce``: 1×1 conv → 16, ReLU, adaptive average pooling to (min(10, H/8), min(15, W/8))
  of the training map (10 × 15 = 2,400 features on 240 × 160);
- ``vector_net``: Linear(3 → 64), ReLU, on ``[x, y, on_fire]`` as the Rust trainer sees them;
- ``fuse``: Linear(2,400 + 64 → 256), ReLU: ``features_dim`` 256.

With SB3's default heads (``pi`` and ``vf`` [64, 64], Tanh) PPO's ``MultiInputPolicy`` then
has exactly the Rust compact policy's 696,791 parameters on 240 × 160 (tested), and SB3's
orthogonal initialisation gives the extractor the gain √2 the Rust trainer uses.

Pass the helicopter coordinates raw (do not list ``helicopter_coord`` in ``VecNormalize``'s
``norm_obs_keys``): the helicopter channel is drawn from them.
"""

from __future__ import annotations

import gymnasium as gym
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn
from torch.nn import functional as F

from ._common import CODE_MAX, FRAME_STACK

#: Features out of the extractor (``features_dim``).
COMPACT_FEATURES = 256


class _Trunk(nn.Module):
    """The authors' three branches with spatial attention, narrowed (16/32, 8/16, 8/16)."""

    def __init__(self, channels: int) -> None:
        super().__init__()
        self.branch_a = nn.Sequential(
            nn.Conv2d(channels, 16, 3, stride=1, padding=1),
            nn.ReLU(),
            nn.MaxPool2d(2),
            nn.Conv2d(16, 32, 3, stride=1, padding=1),
            nn.ReLU(),
            nn.MaxPool2d(2),
        )
        self.branch_b = nn.Sequential(
            nn.Conv2d(channels, 8, 5, stride=2, padding=2),
            nn.ReLU(),
            nn.Conv2d(8, 16, 5, stride=2, padding=2),
            nn.ReLU(),
        )
        self.branch_c = nn.Sequential(
            nn.Conv2d(channels, 8, 11, stride=4, padding=5),
            nn.ReLU(),
            nn.Conv2d(8, 16, 7, stride=2, padding=3),
            nn.ReLU(),
        )
        self.attention = nn.Sequential(nn.Conv2d(64, 32, 1), nn.ReLU(), nn.Conv2d(32, 1, 1), nn.Sigmoid())

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = F.avg_pool2d(x, 2)
        a = self.branch_a(x)
        ah, aw = a.shape[2], a.shape[3]
        # Where a side is not a multiple of 4 the strided convolutions round up and the max
        # pools down: b keeps a's cells.
        b = self.branch_b(x)[:, :, :ah, :aw]
        c = F.interpolate(self.branch_c(x), size=(ah, aw), mode="bilinear", align_corners=False)
        f = torch.cat([a, b, c], dim=1)
        return f * self.attention(f) + f


class CompactExtractor(BaseFeaturesExtractor):
    """FireCast's compact CNN for the ``HelitackEnv`` / ``HelitackVecEnv`` ``Dict`` observation.

    Use it with ``PPO("MultiInputPolicy", env, policy_kwargs={"features_extractor_class":
    CompactExtractor})``. The map it is built for fixes the pooled grid; smaller maps than
    8 × 8 cells are refused.
    """

    def __init__(self, observation_space: gym.spaces.Dict) -> None:
        super().__init__(observation_space, features_dim=COMPACT_FEATURES)
        cells = observation_space["cells"]
        frames, height, width = cells.shape
        if frames != FRAME_STACK or height < 8 or width < 8:
            raise ValueError(
                f"observation_space.cells: expected ({FRAME_STACK}, H ≥ 8, W ≥ 8), got {cells.shape}"
            )
        self.cnn = _Trunk(FRAME_STACK + 1)
        self.reduce = nn.Conv2d(64, 16, 1)
        # Branch a's grid on the training map: two 2× max pools after the 2× average pool.
        self.pooled = (min(10, height // 2 // 4), min(15, width // 2 // 4))
        self.vector_net = nn.Linear(3, 64)
        self.fuse = nn.Linear(16 * self.pooled[0] * self.pooled[1] + 64, COMPACT_FEATURES)

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        cells = observations["cells"].float()
        n, _, height, width = cells.shape
        coord = observations["helicopter_coord"].float()
        # SB3 hands Discrete(2) over one-hot ((N, 2), or (N, 1, 2) from its rollout buffer):
        # the flag is the second column.
        on_fire = observations["on_fire"].float().reshape(n, -1)
        flag = on_fire[:, 1:2] if on_fire.shape[1] == 2 else on_fire[:, :1]
        x = coord[:, 0].round().long().clamp(0, width - 1)
        y = coord[:, 1].round().long().clamp(0, height - 1)
        heli = torch.zeros((n, 1, height, width), dtype=cells.dtype, device=cells.device)
        heli[torch.arange(n, device=cells.device), 0, y, x] = float(CODE_MAX)
        image = torch.cat([cells, heli], dim=1) / float(CODE_MAX)
        f = F.relu(self.reduce(self.cnn(image)))
        f = F.adaptive_avg_pool2d(f, self.pooled).flatten(1)
        v = F.relu(self.vector_net(torch.cat([coord, flag], dim=1)))
        return F.relu(self.fuse(torch.cat([f, v], dim=1)))
