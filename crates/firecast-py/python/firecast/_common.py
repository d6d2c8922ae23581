"""Argument conversion and rendering shared by the single and the vectorised environment."""

from __future__ import annotations

import json
import operator
from collections.abc import Mapping
from typing import Any, Union

import numpy as np
from gymnasium import spaces

from . import _firecast

#: A landscape: ``"procedural:SEED"``, ``"firecastrl:LAND_COVER.png,HEIGHTMAP.png"``, or a
#: mapping ``{"procedural": {"seed": 0, "width": 240, "height": 160, "center": [lat, lon]}}`` /
#: ``{"firecastrl": {"land_cover": PATH, "heightmap": PATH}}``.
Landscape = Union[str, Mapping[str, Any]]
#: An ``EnvConfig`` (firecast-sim) as a mapping or a JSON object string; unknown keys fail.
Config = Union[str, Mapping[str, Any]]

DEFAULT_LANDSCAPE = "procedural:0"
FRAME_STACK: int = _firecast.FRAME_STACK
CODE_MAX: int = _firecast.CODE_MAX
#: Action names by number: grid y points north and x east, and ``render()`` draws north up,
#: so 0 ("north", y + 3) moves the helicopter up in the image (FireCastRL called it "Down").
ACTIONS: tuple[str, ...] = tuple(_firecast.ACTIONS)

# Cell code c: 0 non-burnable, else fire state · 3 + burn index + 1 (state 0 unburnt,
# 1 burning, 2 burnt; BI 0 low, 1 medium, 2 high).
PALETTE = np.array(
    [
        [70, 110, 170],  # 0 non-burnable (water, river, barren)
        [180, 210, 130],  # 1 unburnt, BI low
        [110, 170, 80],  # 2 unburnt, BI medium
        [50, 120, 50],  # 3 unburnt, BI high
        [255, 225, 70],  # 4 burning, BI low
        [255, 140, 30],  # 5 burning, BI medium
        [215, 35, 20],  # 6 burning, BI high
        [125, 115, 105],  # 7 burnt, BI low
        [85, 75, 70],  # 8 burnt, BI medium
        [45, 40, 40],  # 9 burnt, BI high
    ],
    dtype=np.uint8,
)
HELICOPTER_RGB = np.array([255, 255, 255], dtype=np.uint8)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def landscape_arg(landscape: Landscape | None) -> str:
    if landscape is None:
        return DEFAULT_LANDSCAPE
    if isinstance(landscape, str):
        return landscape
    if isinstance(landscape, Mapping):
        return json.dumps(dict(landscape), default=_json_default)
    raise TypeError(f"landscape: expected a str or a mapping, got {type(landscape).__name__}")


def config_arg(config: Config | None) -> str | None:
    if config is None or isinstance(config, str):
        return config
    if isinstance(config, Mapping):
        return json.dumps(dict(config), default=_json_default)
    raise TypeError(f"config: expected a mapping or a JSON string, got {type(config).__name__}")


def action_arg(action: Any) -> int:
    """An integer action from an int, a numpy integer or a one-element integer array."""
    try:
        return operator.index(action)
    except TypeError:
        pass
    a = np.asarray(action)
    if a.size == 1 and np.issubdtype(a.dtype, np.integer):
        return int(a.reshape(()).item())
    raise ValueError(f"action: expected an integer in 0..=4, got {action!r}")


def seed_arg(seed: Any, key: str) -> int:
    try:
        s = operator.index(seed)
    except TypeError:
        raise TypeError(f"{key}: expected an integer, got {type(seed).__name__}") from None
    if not 0 <= s < 2**64:
        raise ValueError(f"{key}: {s} is outside 0..2**64")
    return s


def observation_space(width: int, height: int) -> spaces.Dict:
    """``cells`` holds the true code range [0, 9]; docs/guides/python.md says why not 255."""
    return spaces.Dict(
        {
            "cells": spaces.Box(low=0, high=CODE_MAX, shape=(FRAME_STACK, height, width), dtype=np.uint8),
            "helicopter_coord": spaces.Box(
                low=np.zeros(2, dtype=np.int32),
                high=np.array([width - 1, height - 1], dtype=np.int32),
                dtype=np.int32,
            ),
            "on_fire": spaces.Discrete(2),
        }
    )


def render_rgb(frame: np.ndarray, helicopter: tuple[int, int], scale: int) -> np.ndarray:
    """(H·scale, W·scale, 3) uint8, north up (image row 0 is grid row H − 1)."""
    img = PALETTE[frame[::-1]]
    if scale > 1:
        img = np.repeat(np.repeat(img, scale, axis=0), scale, axis=1)
    x, y = helicopter
    row = frame.shape[0] - 1 - y
    img[row * scale : (row + 1) * scale, x * scale : (x + 1) * scale] = HELICOPTER_RGB
    return img
