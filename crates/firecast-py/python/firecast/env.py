"""``HelitackEnv``: the helitack environment as a ``gymnasium.Env``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from . import _firecast
from ._common import (
    ACTIONS,
    Config,
    Landscape,
    action_arg,
    config_arg,
    landscape_arg,
    observation_space,
    render_rgb,
    seed_arg,
)

RESET_OPTIONS = ("episode_seed",)


class HelitackEnv(gym.Env):
    """A helicopter fighting one wildfire (docs/spec/learning.md §2; the Rust ``WildfireEnv``).

    Args:
        profile: reward preset, ``"p2"`` (the default), ``"websocket_t"``, ``"p1_improved"`` or ``"suppression"``.
        landscape: ``"procedural:SEED"`` (240 × 160), ``"firecastrl:LC.png,HM.png"``, or a mapping
            ``{"procedural": {"seed": 0, "width": 48, "height": 32}}`` /
            ``{"firecastrl": {"land_cover": ..., "heightmap": ...}}``. Default ``procedural:0``.
        config: firecast-sim's ``EnvConfig`` as a mapping or JSON string, e.g.
            ``{"max_steps": 500, "ignition": [20, 15], "sim": {"wind": {"speed_mph": 10,
            "from_direction_deg": 270}}}``. Unknown keys raise ``ValueError`` naming the key.
            ``config["reward"]`` (weights over P2's) and ``profile`` exclude each other.
        render_mode: ``None`` or ``"rgb_array"``.
        render_scale: pixels per cell side in ``render()``.

    Observation (``Dict``): ``cells`` uint8 (4, H, W), the last four frames of cell codes (0
    non-burnable, else fire state · 3 + burn index + 1, oldest frame first);
    ``helicopter_coord`` int32 [x, y]; ``on_fire`` 1 when the helicopter's cell burns.
    Actions (``Discrete(5)``, names in ``firecast.ACTIONS``): 0 north (y + 3), 1 south (y − 3),
    2 west (x − 3), 3 east (x + 3), 4 drop. Grid y points north and ``render()`` draws north
    up, so action 0 moves the helicopter up in the image.

    ``step()`` before the first ``reset()`` raises ``gymnasium.error.ResetNeeded`` (as
    ``gymnasium.make``'s order check does). ``reset(seed=...)`` seeds ``np_random``; every reset draws the simulator's episode seed from
    it, so unseeded resets after a seeded one repeat. ``reset(options={"episode_seed": s})``
    plays the episode of Rust seed ``s`` (what ``HelitackVecEnv`` plays, see its docs).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 8}

    def __init__(
        self,
        profile: str | None = None,
        landscape: Landscape | None = None,
        config: Config | None = None,
        render_mode: str | None = None,
        render_scale: int = 4,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode: {render_mode!r} is not one of {self.metadata['render_modes']} or None")
        if int(render_scale) < 1:
            raise ValueError(f"render_scale: must be at least 1, got {render_scale}")
        self._args = (landscape_arg(landscape), config_arg(config), profile)
        self._env: _firecast.Env | None = _firecast.Env(*self._args)
        self.render_mode = render_mode
        self.render_scale = int(render_scale)
        self.profile = profile or "p2"
        self.observation_space = observation_space(self._env.width, self._env.height)
        self.action_space = spaces.Discrete(5)
        # Gymnasium's order (what ``gymnasium.make``'s OrderEnforcing checks), kept by the
        # class itself so an environment built directly cannot step an episode nobody reset.
        self._needs_reset = True

    def _rust(self) -> _firecast.Env:
        if self._env is None:
            raise RuntimeError("the environment is closed (reset() reopens it)")
        return self._env

    @property
    def width(self) -> int:
        return self._rust().width

    @property
    def height(self) -> int:
        return self._rust().height

    @property
    def max_steps(self) -> int:
        """Truncation length (``config["max_steps"]``)."""
        return self._rust().max_steps

    @property
    def dt_min(self) -> float:
        """Simulated minutes per step."""
        return self._rust().dt_min

    def reset(
        self, *, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        super().reset(seed=seed)
        episode_seed = int(self.np_random.integers(0, 2**64, dtype=np.uint64))
        if options:
            unknown = sorted(set(options) - set(RESET_OPTIONS))
            if unknown:
                raise ValueError(f"options: unknown key(s) {unknown} (known: {list(RESET_OPTIONS)})")
            if "episode_seed" in options:
                episode_seed = seed_arg(options["episode_seed"], "options.episode_seed")
        if self._env is None:
            # Reopened after close(), as SB3's checker expects: same landscape and config.
            self._env = _firecast.Env(*self._args)
        obs, info = self._env.reset(episode_seed)
        self._needs_reset = False
        info["episode_seed"] = episode_seed
        return obs, info

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        env = self._rust()
        if self._needs_reset:
            raise gym.error.ResetNeeded("HelitackEnv.step() before reset(): call reset() first to start an episode")
        return env.step(action_arg(action))

    def get_action_meanings(self) -> list[str]:
        """Action names by number (as Atari environments offer): north, south, west, east, drop."""
        return list(ACTIONS)

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn(
                "HelitackEnv.render() was called without a render_mode; "
                'create the environment with render_mode="rgb_array".'
            )
            return None
        env = self._rust()
        return render_rgb(env.current_frame(), env.helicopter, self.render_scale)

    def close(self) -> None:
        """Frees the simulator; safe to call twice. A later ``reset()`` builds it again."""
        self._env = None
        self._needs_reset = True
