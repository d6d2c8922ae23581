"""``HelitackVecEnv``: the Rust ``VecEnv`` as a Stable-Baselines3 ``VecEnv``."""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from . import _firecast
from ._common import (
    Config,
    Landscape,
    config_arg,
    landscape_arg,
    observation_space,
    render_rgb,
    seed_arg,
)

# Read-only attributes every sub-environment shares (``get_attr``).
_SHARED_ATTRS = ("render_mode", "observation_space", "action_space", "metadata", "profile", "spec")


class HelitackVecEnv(VecEnv):
    """``num_envs`` helitack environments stepped together in Rust (rayon, GIL released).

    The Stable-Baselines3 2.x ``VecEnv`` contract: ``reset()`` returns observations only
    (infos in ``reset_infos``); ``step`` returns ``(obs, rewards, dones, infos)`` with
    same-step autoreset: where ``dones[i]``, ``obs`` is already the next episode's first
    observation, ``infos[i]["terminal_observation"]`` the finished episode's last,
    ``infos[i]["episode"] = {"r", "l", "t"}`` its return, length and the seconds since this
    object was made (as ``VecMonitor`` writes them). ``infos[i]["TimeLimit.truncated"]`` is
    set every step, ``truncated and not terminated`` (as ``DummyVecEnv`` does). Because of
    the built-in episode statistics, ``env_is_wrapped(Monitor)`` answers True.

    The fire pool is every landscape of ``landscapes`` (default ``[landscape]``) × every cell of
    ``ignitions`` (default: the configured ignition), or ``fires``: a list of mappings
    ``{"landscape": ..., "config": ...}``, each fire with its own landscape, weather and ignition
    (``config.ignition``), as a FireCast fire file draws them (``firecast bench quality`` trains
    SB3 on a recipe's training fires this way). Episode ``k`` of environment ``i`` after
    ``reset`` with base seed ``s`` uses Rust seed ``mix(s, i, k)`` and pool entry
    ``mix(s, i, k) mod len(pool)`` (firecast-sim ``VecEnv``), so the stream depends on the seed
    only. ``seed(s)`` sets the base seed of the next ``reset()``; a ``reset()`` without one draws
    it from a generator seeded by the last ``seed(s)``. ``seed=s`` in the constructor is
    ``seed(s)``: the first ``reset()`` uses base seed ``s``.

    Observations: ``cells`` uint8 (N, 4, H, W), ``helicopter_coord`` int32 (N, 2), ``on_fire``
    int64 (N,); rewards float32 (N,).
    """

    def __init__(
        self,
        num_envs: int = 8,
        *,
        seed: int | None = None,
        profile: str | None = None,
        landscape: Landscape | None = None,
        landscapes: Sequence[Landscape] | None = None,
        ignitions: Sequence[tuple[int, int]] | None = None,
        config: Config | None = None,
        render_mode: str | None = None,
        render_scale: int = 4,
        fires: Sequence[Mapping[str, Any]] | None = None,
    ) -> None:
        if landscape is not None and landscapes is not None:
            raise ValueError("give landscape or landscapes, not both")
        if fires is not None and any(x is not None for x in (landscape, landscapes, ignitions, config)):
            raise ValueError("fires gives each fire its landscape and config: leave landscape(s), ignitions and config out")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: {render_mode!r} is not 'rgb_array' or None")
        pairs = None
        if fires is not None:
            lands = []
            pairs = [(landscape_arg(f["landscape"]), config_arg(f["config"]) or "{}") for f in fires]
        else:
            lands = [landscape_arg(x) for x in (landscapes if landscapes is not None else [landscape])]
        cells = None if ignitions is None else [(int(x), int(y)) for x, y in ignitions]
        self._rng = np.random.default_rng(seed)
        # The Rust VecEnv starts reset with this seed; nothing is observable before reset().
        self._vec: _firecast.VecEnv | None = _firecast.VecEnv(
            int(num_envs),
            0 if seed is None else seed_arg(seed, "seed"),
            lands,
            cells,
            config_arg(config),
            profile,
            pairs,
        )
        self.render_mode = render_mode
        self.render_scale = int(render_scale)
        self.profile = profile or "p2"
        self.spec = None
        self.width, self.height = self._vec.width, self._vec.height
        self._custom: list[dict[str, Any]] = [{} for _ in range(int(num_envs))]
        super().__init__(int(num_envs), observation_space(self.width, self.height), spaces.Discrete(5))
        self.metadata["render_fps"] = 8
        if seed is not None:
            self.seed(seed)
        self._actions: np.ndarray | None = None
        self._obs: dict[str, np.ndarray] | None = None
        self._ep_return = np.zeros(self.num_envs, dtype=np.float64)
        self._ep_length = np.zeros(self.num_envs, dtype=np.int64)
        self._t_start = time.time()
        self._started = False

    # -- SB3 VecEnv interface ---------------------------------------------------------------

    def _draw_seed(self) -> int:
        return int(self._rng.integers(0, 2**64, dtype=np.uint64))

    def _rust(self) -> _firecast.VecEnv:
        if self._vec is None:
            raise RuntimeError("the environment is closed")
        return self._vec

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Base seed of the next ``reset()`` (one for all environments; see the class docs)."""
        if seed is None:
            seed = int(np.random.randint(0, np.iinfo(np.uint32).max, dtype=np.uint32))
        seed = seed_arg(seed, "seed")
        self._rng = np.random.default_rng(seed)
        self._seeds = [seed] * self.num_envs
        return list(self._seeds)

    def reset(self) -> VecEnvObs:
        base = self._seeds[0]
        if base is None:
            base = self._draw_seed()
        obs, infos = self._rust().reset(int(base))
        self._reset_seeds()
        self._reset_options()
        for info in infos:
            info["base_seed"] = int(base)
        self.reset_infos = infos
        self._obs = obs
        self._ep_return[:] = 0.0
        self._ep_length[:] = 0
        self._actions = None
        self._started = True
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        a = np.asarray(actions)
        if not np.issubdtype(a.dtype, np.integer):
            raise ValueError(f"actions: expected integers in 0..=4, got dtype {a.dtype}")
        self._actions = a.reshape(-1).astype(np.int64, copy=False)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        if not self._started:
            raise RuntimeError("call reset() before step()")
        actions, self._actions = self._actions, None
        obs, rewards, terminated, truncated, infos, terminal = self._rust().step(actions)
        dones = terminated | truncated
        self._ep_return += rewards
        self._ep_length += 1
        for i, info in enumerate(infos):
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        for i, final_obs in terminal:
            info = infos[i]
            info["terminal_observation"] = final_obs
            info["episode"] = {
                "r": float(self._ep_return[i]),
                "l": int(self._ep_length[i]),
                "t": round(time.time() - self._t_start, 6),
            }
            self._ep_return[i] = 0.0
            self._ep_length[i] = 0
        self._obs = obs
        return obs, rewards, dones, infos

    def close(self) -> None:
        self._vec = None

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, (int, np.integer)):
            return [int(indices)]
        assert isinstance(indices, Iterable)
        return [int(i) for i in indices]

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        idx = self._indices(indices)
        if attr_name in _SHARED_ATTRS:
            value = getattr(self, attr_name)
            return [value for _ in idx]
        if attr_name in ("fire_index", "episode_index"):
            vec = self._rust()
            return [getattr(vec, attr_name)(i) for i in idx]
        if all(attr_name in self._custom[i] for i in idx):
            return [self._custom[i][attr_name] for i in idx]
        raise AttributeError(f"HelitackVecEnv environments have no attribute {attr_name!r}")

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        if attr_name in _SHARED_ATTRS or attr_name in ("fire_index", "episode_index"):
            raise AttributeError(f"{attr_name!r} is fixed when a HelitackVecEnv is made")
        for i in self._indices(indices):
            self._custom[i][attr_name] = value

    def env_method(self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs) -> list[Any]:
        idx = self._indices(indices)
        if method_name == "render":
            images = self.get_images()
            return [images[i] for i in idx]
        if method_name in ("fire_index", "episode_index"):
            return self.get_attr(method_name, idx)
        raise AttributeError(f"HelitackVecEnv environments have no method {method_name!r} (render, fire_index, episode_index)")

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        # Each environment reports Monitor's `episode` info itself, so it counts as wrapped
        # by Monitor (and by its base classes); no other wrapper is applied.
        wrapped = issubclass(Monitor, wrapper_class)
        return [wrapped for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self._obs is None:
            raise RuntimeError("call reset() before rendering")
        frames = self._obs["cells"][:, -1]
        coords = self._obs["helicopter_coord"]
        return [render_rgb(frames[i], (int(coords[i, 0]), int(coords[i, 1])), self.render_scale) for i in range(self.num_envs)]

    # -- extras -----------------------------------------------------------------------------

    @property
    def num_fires(self) -> int:
        """Size of the fire pool."""
        return self._rust().num_fires

    @property
    def max_steps(self) -> int:
        return self._rust().max_steps
