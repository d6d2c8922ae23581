"""What a new user runs into first: action names against the render, the reset order, tiny
landscapes and cells off the map (issue 31's list)."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from conftest import SMALL_LANDSCAPE

import firecast
from firecast import _firecast

START = (24, 16)
# Where each named action takes the helicopter from START (3 cells a move; grid y points north).
MOVES = {"north": (24, 19), "south": (24, 13), "west": (21, 16), "east": (27, 16), "drop": START}
# Pixel offset of the helicopter on the north-up render (scale 1): (columns, rows).
ON_SCREEN = {"north": (0, -3), "south": (0, 3), "west": (-3, 0), "east": (3, 0), "drop": (0, 0)}


def helicopter_pixel(img: np.ndarray) -> tuple[int, int]:
    """(column, row) of the white helicopter cell in a scale-1 render."""
    rows, cols = np.nonzero((img == 255).all(axis=2))
    assert len(rows) == 1, "one white cell"
    return int(cols[0]), int(rows[0])


def test_action_names_agree_with_the_observation_and_the_north_up_render():
    assert firecast.ACTIONS == ("north", "south", "west", "east", "drop")
    env = firecast.HelitackEnv(
        render_mode="rgb_array",
        render_scale=1,
        landscape=SMALL_LANDSCAPE,
        config={"max_steps": 20, "helicopter_start": list(START)},
    )
    assert env.get_action_meanings() == list(firecast.ACTIONS)
    for action, name in enumerate(firecast.ACTIONS):
        obs, _ = env.reset(seed=0)
        assert tuple(obs["helicopter_coord"]) == START
        before = helicopter_pixel(env.render())
        obs, *_ = env.step(action)
        assert tuple(obs["helicopter_coord"]) == MOVES[name], name
        after = helicopter_pixel(env.render())
        assert (after[0] - before[0], after[1] - before[1]) == ON_SCREEN[name], name
        # The render is the newest observed frame flipped north up: image row r is grid row H-1-r.
        x, y = obs["helicopter_coord"]
        assert after == (x, env.height - 1 - y)


def test_step_before_reset_is_an_error():
    env = firecast.HelitackEnv(landscape=SMALL_LANDSCAPE)
    with pytest.raises(gymnasium.error.ResetNeeded, match=r"step\(\) before reset\(\)"):
        env.step(0)
    env.reset(seed=0)
    env.step(0)
    # The Rust class under it refuses too.
    raw = _firecast.Env('{"procedural": {"seed": 3, "width": 48, "height": 32}}')
    with pytest.raises(RuntimeError, match=r"step\(\) before reset\(\): call reset\(\) first"):
        raw.step(0)
    raw.reset(0)
    raw.step(0)
    # And so does an environment from gymnasium.make (Gymnasium's own order check).
    made = gymnasium.make(firecast.ENV_ID, landscape=SMALL_LANDSCAPE)
    with pytest.raises(gymnasium.error.ResetNeeded):
        made.step(0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"landscape": {"procedural": {"seed": 1, "width": 2, "height": 2}}}, r"landscape: the 2 × 2 grid is too small: .* at least 8 × 8 cells"),
        ({"landscape": {"procedural": {"seed": 1, "width": 48, "height": 7}}}, r"landscape: the 48 × 7 grid is too small"),
        ({"config": {"ignition": [48, 2]}}, r"config\.ignition: cell \(48, 2\) is outside the 48 × 32 landscape \(x in 0\.\.48, y in 0\.\.32\)"),
        ({"config": {"helicopter_start": [3, 32]}}, r"config\.helicopter_start: cell \(3, 32\) is outside the 48 × 32 landscape"),
    ],
)
def test_tiny_landscapes_and_cells_off_the_map_name_their_key(kwargs, match):
    args = {"landscape": SMALL_LANDSCAPE, **kwargs}
    with pytest.raises(ValueError, match=match):
        firecast.HelitackEnv(**args)


def test_the_vec_env_names_the_landscape_it_refuses():
    tiny = [{"procedural": {"seed": s, "width": 4, "height": 4}} for s in (1, 2)]
    with pytest.raises(ValueError, match=r"landscapes\[0\]: the 4 × 4 grid is too small"):
        firecast.HelitackVecEnv(2, landscapes=tiny)
    with pytest.raises(ValueError, match=r"config\.ignition: cell \(60, 1\) is outside the 48 × 32 landscape"):
        firecast.HelitackVecEnv(2, landscape=SMALL_LANDSCAPE, config={"ignition": [60, 1]})
    # The smallest accepted grid plays.
    env = firecast.HelitackEnv(landscape={"procedural": {"seed": 1, "width": 8, "height": 8}})
    env.reset(seed=0)
    env.step(4)
