"""HelitackVecEnv: SB3's VecEnv contract, parity with the Rust VecEnv and the single env."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from conftest import RANDOM_SIM, SMALL_LANDSCAPE, small
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import VecCheckNan, VecEnv

import firecast
from firecast import HelitackVecEnv

MASK = (1 << 64) - 1


def mix_seed(base: int, env: int, episode: int) -> int:
    """firecast-sim's VecEnv episode seed (`mix_seed` in crates/firecast-sim/src/env.rs)."""
    z = base ^ ((env * 0x9E3779B97F4A7C15) & MASK) ^ ((episode * 0xD1B54A32D192ED03) & MASK)
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def assert_same_obs(a, b):
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_is_an_sb3_vec_env_with_numpy_batches():
    vec = HelitackVecEnv(3, seed=0, **small())
    assert isinstance(vec, VecEnv) and vec.num_envs == 3
    obs = vec.reset()
    assert obs["cells"].shape == (3, 4, 32, 48) and obs["cells"].dtype == np.uint8
    assert obs["helicopter_coord"].shape == (3, 2) and obs["helicopter_coord"].dtype == np.int32
    assert obs["on_fire"].shape == (3,) and obs["on_fire"].dtype == np.int64
    assert len(vec.reset_infos) == 3 and vec.reset_infos[0]["base_seed"] == 0
    obs, rewards, dones, infos = vec.step(np.array([4, 0, 3]))
    assert rewards.dtype == np.float32 and rewards.shape == (3,)
    assert dones.dtype == np.bool_ and not dones.any()
    assert len(infos) == 3 and infos[0]["drops"] == 1 and infos[1]["drops"] == 0
    assert all(info["TimeLimit.truncated"] is False for info in infos)
    for i in range(3):
        assert {k: v[i] for k, v in obs.items()} in vec.observation_space


def test_terminal_observation_time_limit_and_episode_info():
    n, steps = 4, 5
    vec = HelitackVecEnv(n, seed=1, **small(max_steps=steps))
    obs = vec.reset()
    total = np.zeros(n)
    last = obs
    for t in range(1, steps + 1):
        actions = np.array([0, 1, 2, 3])
        obs, rewards, dones, infos = vec.step(actions)
        total += rewards
        if t < steps:
            assert not dones.any()
            assert all("terminal_observation" not in i and "episode" not in i for i in infos)
            last = obs
    # The fire still burns at step 5: every episode is truncated by the time limit.
    assert dones.all()
    for i, info in enumerate(infos):
        assert info["TimeLimit.truncated"] is True and info["step"] == steps and info["cells_burning"] > 0
        term = info["terminal_observation"]
        assert term in vec.observation_space
        # The final observation continues the previous one; obs[i] is already a new episode.
        assert np.array_equal(term["cells"][:3], last["cells"][i][1:])
        new = obs["cells"][i]
        assert all(np.array_equal(new[k], new[0]) for k in range(4)), "a reset fills the stack with one frame"
        assert not np.array_equal(term["cells"], new)
        assert info["episode"]["l"] == steps
        assert info["episode"]["r"] == pytest.approx(total[i], rel=1e-5)
        assert info["episode"]["t"] >= 0.0
    assert [vec.get_attr("episode_index", i)[0] for i in range(n)] == [1] * n


def test_termination_is_not_a_time_limit():
    # Without wind on a 12 x 10 map the fire dies out well before max_steps.
    vec = HelitackVecEnv(2, seed=0, landscape={"procedural": {"seed": 2, "width": 12, "height": 10}}, config={"max_steps": 500})
    vec.reset()
    seen = 0
    for _ in range(500):
        _, _, dones, infos = vec.step(np.array([4, 4]))
        for done, info in zip(dones, infos):
            if done:
                seen += 1
                assert info["TimeLimit.truncated"] is False and info["step"] < 500
    assert seen > 0


def test_reproduces_the_rust_vec_env(rust_streams):
    v = rust_streams["vec"]
    vec = HelitackVecEnv(v["num_envs"], seed=v["seed"], landscape=rust_streams["landscape"], config=rust_streams["config"])
    obs = vec.reset()
    n = v["num_envs"]

    def check(o, ref):
        assert o["cells"].tobytes() == bytes.fromhex(ref["cells"])
        assert np.asarray(o["helicopter_coord"]).reshape(-1).tolist() == list(ref["agent"])
        assert np.asarray(o["on_fire"]).reshape(-1).tolist() == [int(x) for x in np.atleast_1d(ref["on_fire"])]

    check(obs, v["reset"])
    ends = 0
    for actions, ref in zip(v["actions"], v["steps"]):
        obs, rewards, dones, infos = vec.step(np.array(actions))
        check(obs, ref)
        assert rewards.tolist() == np.array(ref["rewards"], dtype=np.float32).tolist()
        assert dones.tolist() == [a or b for a, b in zip(ref["terminated"], ref["truncated"])]
        for t in ref["terminal"]:
            ends += 1
            check(infos[t["env"]]["terminal_observation"], t)
        assert sum(dones) == len(ref["terminal"])
    assert ends >= n


def test_matches_the_single_env_episode_by_episode():
    n, base, max_steps = 3, 42, 15
    kwargs = small(max_steps=max_steps, sim=RANDOM_SIM)
    vec = HelitackVecEnv(n, seed=base, **kwargs)
    obs = vec.reset()
    singles = [firecast.HelitackEnv(**kwargs) for _ in range(n)]
    episode = [0] * n
    single_obs = [env.reset(options={"episode_seed": mix_seed(base, i, 0)})[0] for i, env in enumerate(singles)]
    for i in range(n):
        assert_same_obs({k: v[i] for k, v in obs.items()}, single_obs[i])
    rng = np.random.default_rng(0)
    ends, outcomes = 0, set()
    for _ in range(40):
        actions = rng.integers(0, 5, size=n)
        obs, rewards, dones, infos = vec.step(actions)
        for i, env in enumerate(singles):
            o, r, te, tr, info = env.step(int(actions[i]))
            assert np.float32(r) == rewards[i]
            assert (te or tr) == bool(dones[i])
            assert info["cells_burnt"] == infos[i]["cells_burnt"] and info["step"] == infos[i]["step"]
            if te or tr:
                ends += 1
                outcomes.add(info["cells_burnt"])
                assert_same_obs(infos[i]["terminal_observation"], o)
                assert infos[i]["TimeLimit.truncated"] == (tr and not te)
                episode[i] += 1
                o, _ = env.reset(options={"episode_seed": mix_seed(base, i, episode[i])})
            assert_same_obs({k: v[i] for k, v in obs.items()}, o)
    # Episodes end differently, so a wrong episode seed would have shown.
    assert ends >= n and len(outcomes) > 1


def test_seeding_is_reproducible():
    def stream(vec, resets):
        out = []
        rng = np.random.default_rng(1)
        for _ in range(resets):
            out.append(vec.reset()["cells"].copy())
            for _ in range(20):
                o, r, d, _ = vec.step(rng.integers(0, 5, size=vec.num_envs))
                out += [o["cells"].copy(), r.copy(), d.copy()]
        return out

    kw = small(max_steps=8)
    a, b = HelitackVecEnv(2, seed=9, **kw), HelitackVecEnv(2, **kw)
    assert b.seed(9) == [9, 9]
    sa, sb = stream(a, 3), stream(b, 3)
    assert all(np.array_equal(x, y) for x, y in zip(sa, sb))
    # The base seeds of unseeded resets come from the seeded generator.
    a.seed(9)
    a.reset()
    first = a.reset_infos[0]["base_seed"]
    a.reset()
    second = a.reset_infos[0]["base_seed"]
    b.seed(9)
    b.reset()
    b.reset()
    assert first == 9 and second != 9 and b.reset_infos[0]["base_seed"] == second


def test_fire_pool_of_landscapes_and_ignitions():
    lands = [{"procedural": {"seed": s, "width": 48, "height": 32}} for s in (3, 4)]
    vec = HelitackVecEnv(6, seed=0, landscapes=lands, ignitions=[(10, 10), (30, 20), (40, 5)], config={"max_steps": 4})
    assert vec.num_fires == 6
    vec.reset()
    fires = set()
    for _ in range(40):
        vec.step(np.zeros(6, dtype=np.int64))
        fires.update(vec.get_attr("fire_index"))
    assert len(fires) >= 4
    with pytest.raises(ValueError, match=r"landscapes\[1\]: is 40 × 32, landscapes\[0\] is 48 × 32"):
        HelitackVecEnv(2, landscapes=[lands[0], {"procedural": {"seed": 1, "width": 40, "height": 32}}])
    with pytest.raises(ValueError, match=r"landscapes\[1\]\.procedural\.sede: unknown field `sede`"):
        HelitackVecEnv(2, landscapes=[lands[0], {"procedural": {"sede": 1}}])
    with pytest.raises(ValueError, match=r"ignitions\[1\]: cell \(99, 0\) is outside"):
        HelitackVecEnv(2, landscape=SMALL_LANDSCAPE, ignitions=[(1, 1), (99, 0)])
    with pytest.raises(ValueError, match="num_envs: must be at least 1"):
        HelitackVecEnv(0, landscape=SMALL_LANDSCAPE)
    with pytest.raises(ValueError, match="landscape or landscapes"):
        HelitackVecEnv(2, landscape=SMALL_LANDSCAPE, landscapes=lands)


def test_vec_env_methods_attributes_and_close():
    vec = HelitackVecEnv(2, seed=0, render_mode="rgb_array", render_scale=2, **small())
    vec.reset()
    assert vec.get_attr("render_mode") == ["rgb_array", "rgb_array"]
    assert vec.get_attr("observation_space", 1) == [vec.observation_space]
    vec.set_attr("difficulty", 3, indices=[1])
    assert vec.get_attr("difficulty", 1) == [3]
    with pytest.raises(AttributeError):
        vec.get_attr("difficulty")
    with pytest.raises(AttributeError):
        vec.set_attr("render_mode", "human")
    assert vec.env_method("fire_index") == [0, 0]
    with pytest.raises(AttributeError, match="no method 'jump'"):
        vec.env_method("jump")
    assert vec.env_is_wrapped(Monitor) == [True, True]
    assert vec.env_is_wrapped(gymnasium.Wrapper) == [True, True]
    assert vec.env_is_wrapped(gymnasium.wrappers.TimeLimit) == [False, False]
    img = vec.render()
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8
    assert vec.env_method("render", indices=[0])[0].shape == (64, 96, 3)
    with pytest.raises(ValueError, match=r"actions\[1\]: 7 is not an action"):
        vec.step(np.array([0, 7]))
    with pytest.raises(ValueError, match="actions: expected integers"):
        vec.step(np.array([0.5, 1.0]))
    with pytest.raises(ValueError, match="actions: 3 actions for 2 environments"):
        vec.step(np.array([0, 1, 2]))
    checked = VecCheckNan(vec, raise_exception=True)
    checked.reset()
    checked.step(np.array([4, 4]))
    vec.close()
    vec.close()
    with pytest.raises(RuntimeError, match="closed"):
        vec.reset()


def test_fires_each_with_its_own_landscape_weather_and_ignition():
    def fire(seed, ignition, wind):
        return {
            "landscape": {"procedural": {"seed": seed, "width": 48, "height": 32}},
            "config": {"max_steps": 6, "ignition": ignition, "sim": {"wind": {"speed_mph": wind, "from_direction_deg": 90}}},
        }

    a, b = fire(3, [10, 10], 4.0), fire(4, [30, 20], 1.0)

    def stream(vec):
        out = [vec.reset()["cells"].copy()]
        for _ in range(12):
            o, r, d, _ = vec.step(np.full(vec.num_envs, 4, dtype=np.int64))
            out += [o["cells"].copy(), r.copy(), d.copy()]
        return out

    # One fire given as a pair plays exactly what the same landscape and config play.
    one = HelitackVecEnv(2, seed=5, fires=[a])
    same = HelitackVecEnv(2, seed=5, landscape=a["landscape"], config=a["config"])
    assert all(np.array_equal(x, y) for x, y in zip(stream(one), stream(same)))
    both = HelitackVecEnv(4, seed=0, fires=[a, b])
    assert both.num_fires == 2
    both.reset()
    seen = set()
    for _ in range(30):
        both.step(np.zeros(4, dtype=np.int64))
        seen.update(both.get_attr("fire_index"))
    assert seen == {0, 1}
    with pytest.raises(ValueError, match=r"fires\[1\]\.config\.max_steps: must be at least 1"):
        HelitackVecEnv(2, fires=[a, {"landscape": b["landscape"], "config": {"max_steps": 0}}])
    with pytest.raises(ValueError, match=r"fires\[1\]\.landscape: is 40 × 32, fires\[0\]\.landscape is 48 × 32"):
        HelitackVecEnv(2, fires=[a, fire(1, [5, 5], 1.0) | {"landscape": {"procedural": {"seed": 1, "width": 40, "height": 32}}}])
    with pytest.raises(ValueError, match="leave landscape"):
        HelitackVecEnv(2, fires=[a], config={"max_steps": 3})
