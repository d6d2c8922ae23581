"""HelitackEnv: Gymnasium's and SB3's checkers, determinism, parity with Rust, bad input."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from conftest import RANDOM_SIM, SMALL_LANDSCAPE, small
from gymnasium.utils.env_checker import check_env as gymnasium_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import firecast

# SB3's checker calls every 3-D Box an image and advises [0, 255] bounds and >= 36x36 for
# its CnnPolicy. `cells` declares its true range [0, 9] instead: SB3's is_image_space() then
# treats it as a vector (MultiInputPolicy flattens it), so these two notes do not apply.
SB3_IMAGE_ADVICE = (
    "It seems that your observation space cells is an image but the upper and lower bounds are not in [0, 255]",
    "The minimal resolution for an image is 36x36 for the default `CnnPolicy`",
)


def recorded(fn, *args, **kwargs) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fn(*args, **kwargs)
    return [str(w.message) for w in caught]


def play(env, actions, seed=None):
    """(observations, rewards, terminated, truncated, infos) of reset + the actions."""
    obs, info = env.reset(seed=seed)
    out = [[obs], [], [], [], [info]]
    for a in actions:
        obs, r, te, tr, info = env.step(a)
        for lst, v in zip(out, (obs, r, te, tr, info)):
            lst.append(v)
        if te or tr:
            break
    return out


def assert_same_obs(a, b):
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_import_registers_the_gymnasium_id():
    assert firecast.ENV_ID == "firecast/Helitack-v0"
    assert "firecast/Helitack-v0" in gymnasium.registry
    env = gymnasium.make("firecast/Helitack-v0", **small())
    assert isinstance(env.unwrapped, firecast.HelitackEnv)
    assert env.unwrapped.spec is not None and env.unwrapped.spec.nondeterministic is False


def test_gymnasium_check_env_passes_without_warnings():
    env = gymnasium.make("firecast/Helitack-v0", render_mode="rgb_array", **small())
    # With a spec (made by gymnasium.make) the checker also tests reset determinism,
    # unseeded resets after seeded ones, every render mode and a double close.
    assert recorded(gymnasium_check_env, env.unwrapped) == []
    # The passive checker gymnasium.make wraps around the env stays silent too.
    msgs = recorded(lambda: [env.reset(seed=1)] + [env.step(env.action_space.sample()) for _ in range(20)])
    assert msgs == []


def test_sb3_check_env_passes_with_only_the_image_advice():
    msgs = recorded(sb3_check_env, firecast.HelitackEnv(render_mode="rgb_array", **small()), warn=True, skip_render_check=False)
    unexpected = [m for m in msgs if not m.startswith(SB3_IMAGE_ADVICE)]
    assert unexpected == []


def test_spaces_and_types():
    env = firecast.HelitackEnv(**small())
    obs, info = env.reset(seed=0)
    space = env.observation_space
    assert space["cells"].shape == (4, 32, 48) and space["cells"].dtype == np.uint8
    assert space["cells"].low.min() == 0 and space["cells"].high.max() == 9
    assert space["helicopter_coord"].high.tolist() == [47, 31]
    assert env.action_space == gymnasium.spaces.Discrete(5)
    assert obs in space
    obs, reward, terminated, truncated, info = env.step(np.int64(4))
    assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
    assert obs in space and obs["cells"].dtype == np.uint8 and obs["helicopter_coord"].dtype == np.int32
    for key in ("step", "cells_burning", "cells_burnt", "new_burnt", "quenched_step", "cells_quenched", "drops", "water_used_gal", "sim_time_min"):
        assert key in info
    assert info["step"] == 1 and info["drops"] == 1 and info["water_used_gal"] == 800.0
    assert info["sim_time_min"] == pytest.approx(env.dt_min)


def test_same_seed_same_stream_and_unseeded_resets_repeat():
    rng = np.random.default_rng(5)
    actions = rng.integers(0, 5, size=30).tolist()
    kw = small(max_steps=30, sim=RANDOM_SIM)
    a, b = firecast.HelitackEnv(**kw), firecast.HelitackEnv(**kw)
    outcomes = set()
    for seed in (7, None, None, None, None, None):
        # reset(seed=7) then unseeded resets: both envs must give identical streams.
        sa, sb = play(a, actions, seed), play(b, actions, seed)
        assert len(sa[0]) == len(sb[0]) == 31
        for oa, ob in zip(sa[0], sb[0]):
            assert_same_obs(oa, ob)
        assert sa[1] == sb[1] and sa[2] == sb[2] and sa[3] == sb[3] and sa[4] == sb[4]
        outcomes.add((sa[4][-1]["cells_burnt"], sum(sa[1])))
    # The episode seeds differ and here they change the fire.
    assert len(outcomes) > 1
    seeds = {play(a, [], s)[4][0]["episode_seed"] for s in (7, None, None, 8)}
    assert len(seeds) == 4


def test_episode_seed_option_replays_an_episode():
    env = firecast.HelitackEnv(**small())
    _, info = env.reset(seed=11)
    actions = [4, 0, 3, 4, 1, 2, 4, 4, 3, 0] * 5
    first = play(env, actions, 11)
    again = play(env, actions)  # another episode
    env.reset(options={"episode_seed": info["episode_seed"]})
    replay = [env.step(a) for a in actions[: len(first[1])]]
    assert [r[1] for r in replay] == first[1]
    assert_same_obs(replay[-1][0], first[0][-1])
    assert again[4][0]["episode_seed"] != info["episode_seed"]


def test_single_env_reproduces_the_rust_wildfire_env(rust_streams):
    s = rust_streams["single"]
    env = firecast.HelitackEnv(landscape=rust_streams["landscape"], config=rust_streams["config"])
    obs, _ = env.reset(options={"episode_seed": s["episode_seed"]})

    def check(o, ref):
        assert o["cells"].tobytes() == bytes.fromhex(ref["cells"])
        assert o["helicopter_coord"].tolist() == ref["agent"]
        assert o["on_fire"] == int(ref["on_fire"])

    check(obs, s["reset"])
    assert len(s["steps"]) == 15  # truncated at max_steps
    for a, ref in zip(s["actions"], s["steps"]):
        obs, r, te, tr, info = env.step(a)
        check(obs, ref)
        assert r == ref["reward"] and te == ref["terminated"] and tr == ref["truncated"]
        assert info["cells_burning"] == ref["cells_burning"] and info["cells_burnt"] == ref["cells_burnt"]


def test_profiles_select_the_reward():
    actions = [4, 0, 4, 3, 4, 1, 4, 2] * 4
    rewards = {p: play(firecast.HelitackEnv(profile=p, **small()), actions, 3)[1] for p in firecast.PROFILES}
    assert rewards["p2"] == play(firecast.HelitackEnv(**small()), actions, 3)[1]
    assert len({tuple(r) for r in rewards.values()}) == len(firecast.PROFILES)
    # P2 clips at [-10, 10] and pays -1 per drop on burnt or non-burnable cells.
    assert all(-10 <= r <= 10 for r in rewards["p2"])


def test_config_reaches_the_simulator():
    calm = play(firecast.HelitackEnv(landscape=SMALL_LANDSCAPE, config={"max_steps": 60}), [0, 1] * 30, 0)
    windy = play(firecast.HelitackEnv(**small(max_steps=60)), [0, 1] * 30, 0)
    assert len(calm[1]) == len(windy[1]) == 60
    assert calm[4][-1]["cells_burnt"] != windy[4][-1]["cells_burnt"]
    env = firecast.HelitackEnv(**small(ignition=[5, 6], helicopter_start=[40, 20], max_steps=3))
    obs, _ = env.reset(seed=0)
    assert obs["helicopter_coord"].tolist() == [40, 20]
    assert env.max_steps == 3 and env.unwrapped is env
    *_, truncated, _ = play(env, [0, 0, 0, 0], 0)
    assert truncated[-1] is True and len(truncated) == 3


def test_firecastrl_maps_load(tmp_path):
    # Not available here: a missing file is reported with its path.
    with pytest.raises(FileNotFoundError, match="nope_lc.png"):
        firecast.HelitackEnv(landscape={"firecastrl": {"land_cover": str(tmp_path / "nope_lc.png"), "heightmap": "hm.png"}})
    with pytest.raises(FileNotFoundError, match="a.png"):
        firecast.HelitackEnv(landscape=f"firecastrl:{tmp_path / 'a.png'},{tmp_path / 'b.png'}")


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"config": {"max_step": 5}}, ValueError, r"config\.max_step: unknown field `max_step`"),
        ({"config": {"reward": {"quenchd": 1}}}, ValueError, r"config\.reward\.quenchd: unknown field `quenchd`"),
        ({"config": {"sim": {"wind": {"speed": 3}}}}, ValueError, r"config\.sim\.wind\.speed: unknown field `speed`"),
        ({"config": {"max_steps": -1}}, ValueError, r"config\.max_steps: invalid value"),
        ({"config": {"max_steps": 0}}, ValueError, r"config\.max_steps: must be at least 1"),
        ({"config": "[1, 2]"}, ValueError, "config: expected a mapping"),
        ({"config": "{oops"}, ValueError, "config: not valid JSON"),
        ({"config": {"ignition": [480, 2]}}, ValueError, r"config\.ignition: cell \(480, 2\) is outside the 48 × 32 landscape"),
        ({"profile": "p3"}, ValueError, "profile: unknown profile `p3` \\(use one of p2, websocket_t, p1_improved, suppression\\)"),
        ({"profile": "p2", "config": {"reward": {"step": 0}}}, ValueError, "profile: `p2` and config.reward both set"),
        ({"landscape": "procedural:x"}, ValueError, "landscape: the procedural seed must be a whole number"),
        ({"landscape": "mars:1"}, ValueError, "landscape: expected procedural:SEED"),
        ({"landscape": {"procedurl": {"seed": 1}}}, ValueError, "landscape: unknown variant `procedurl`"),
        ({"landscape": {"procedural": {"seed": 1, "widht": 3}}}, ValueError, r"landscape\.procedural\.widht: unknown field `widht`"),
        ({"landscape": {"procedural": {"seed": 1, "width": 0}}}, ValueError, r"landscape: landscape grid must not be empty \(0 x 160\)"),
        ({"config": {"sim": {"dt_min": -1}}}, ValueError, "dt_min must be positive"),
        ({"config": {"termination": "never"}}, ValueError, "config.termination: unknown variant `never`"),
        ({"config": {"max_steps": object()}}, TypeError, "not JSON serializable|not JSON serialisable"),
        ({"render_mode": "human"}, ValueError, "render_mode"),
    ],
)
def test_bad_arguments_name_the_key(kwargs, error, match):
    args = {"landscape": SMALL_LANDSCAPE, **kwargs}
    with pytest.raises(error, match=match):
        firecast.HelitackEnv(**args)


def test_bad_actions_and_options():
    env = firecast.HelitackEnv(**small())
    env.reset(seed=0)
    for bad in (5, -1, 2**70):
        with pytest.raises((ValueError, OverflowError), match="action"):
            env.step(bad)
    with pytest.raises(ValueError, match="action"):
        env.step(1.5)
    with pytest.raises(ValueError, match=r"options: unknown key\(s\) \['episode'\]"):
        env.reset(options={"episode": 3})
    with pytest.raises(ValueError, match="options.episode_seed"):
        env.reset(options={"episode_seed": -3})
    assert env.step(np.array([2]))[0] is not None  # one-element integer arrays are fine


def test_render_and_close():
    env = firecast.HelitackEnv(render_mode="rgb_array", render_scale=3, **small())
    obs, _ = env.reset(seed=0)
    img = env.render()
    assert img.shape == (32 * 3, 48 * 3, 3) and img.dtype == np.uint8
    x, y = obs["helicopter_coord"]
    row = 31 - y  # north up
    assert img[row * 3 + 1, x * 3 + 1].tolist() == [255, 255, 255]
    assert len(np.unique(img.reshape(-1, 3), axis=0)) >= 3
    env.close()
    env.close()  # double close is fine
    with pytest.raises(RuntimeError, match="closed"):
        env.step(0)
    env.reset(seed=0)  # reset reopens it (SB3's checker resets after close)
    env.step(0)
    quiet = firecast.HelitackEnv(**small())
    quiet.reset(seed=0)
    msgs: list = []
    assert recorded(lambda: msgs.append(quiet.render())) != [] and msgs == [None]
