"""FireCast's compact CNN as an SB3 features extractor, and SB3's VecNormalize on the Dict
observation, as docs/guides/python.md documents them."""

from __future__ import annotations

import pathlib
import re

import numpy as np
import pytest
import torch
from conftest import small
from stable_baselines3 import PPO
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.vec_env import VecNormalize

from firecast import CompactExtractor, HelitackVecEnv

GUIDE = pathlib.Path(__file__).resolve().parents[4] / "docs" / "guides" / "python.md"


def quiet(model: PPO) -> PPO:
    model.set_logger(Logger(folder=None, output_formats=[]))
    return model


def test_the_guides_vec_normalize_and_extractor_example_runs_as_written():
    torch.set_num_threads(1)
    text = GUIDE.read_text(encoding="utf-8")
    blocks = [b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S) if "norm_obs_keys" in b]
    assert len(blocks) == 1, "one documented VecNormalize example"
    scope: dict = {}
    exec(compile(blocks[0], str(GUIDE), "exec"), scope)  # noqa: S102 - the documented example
    model = scope["model"]
    assert model.num_timesteps >= 256
    assert isinstance(model.policy.features_extractor, CompactExtractor)


def test_vec_normalize_with_defaults_names_on_fire_and_norm_obs_keys_works():
    vec = HelitackVecEnv(2, seed=0, **small(max_steps=50))
    with pytest.raises(ValueError, match="on_fire"):
        VecNormalize(vec)
    norm = VecNormalize(vec, norm_obs_keys=["helicopter_coord"])
    obs = norm.reset()
    for _ in range(5):
        obs, *_ = norm.step(np.array([0, 3]))
    assert obs["cells"].dtype == np.uint8 and obs["cells"].max() <= 9
    assert obs["helicopter_coord"].dtype.kind == "f"
    assert set(np.unique(obs["on_fire"]).tolist()) <= {0, 1}
    raw = norm.get_original_obs()
    assert raw["helicopter_coord"].dtype == np.int32


def test_compact_extractor_has_the_rust_compact_policys_layers():
    torch.set_num_threads(1)
    # The paper's 240 × 160 map: SB3's default heads make the Rust compact policy's 696,791.
    vec = HelitackVecEnv(1, seed=0)
    model = PPO(
        "MultiInputPolicy",
        vec,
        n_steps=16,
        batch_size=16,
        device="cpu",
        policy_kwargs={"features_extractor_class": CompactExtractor},
    )
    assert sum(p.numel() for p in model.policy.parameters()) == 696_791
    shapes = {k: tuple(v.shape) for k, v in model.policy.state_dict().items() if k.startswith("features_extractor.")}
    assert shapes == {
        "features_extractor.cnn.branch_a.0.weight": (16, 5, 3, 3),
        "features_extractor.cnn.branch_a.0.bias": (16,),
        "features_extractor.cnn.branch_a.3.weight": (32, 16, 3, 3),
        "features_extractor.cnn.branch_a.3.bias": (32,),
        "features_extractor.cnn.branch_b.0.weight": (8, 5, 5, 5),
        "features_extractor.cnn.branch_b.0.bias": (8,),
        "features_extractor.cnn.branch_b.2.weight": (16, 8, 5, 5),
        "features_extractor.cnn.branch_b.2.bias": (16,),
        "features_extractor.cnn.branch_c.0.weight": (8, 5, 11, 11),
        "features_extractor.cnn.branch_c.0.bias": (8,),
        "features_extractor.cnn.branch_c.2.weight": (16, 8, 7, 7),
        "features_extractor.cnn.branch_c.2.bias": (16,),
        "features_extractor.cnn.attention.0.weight": (32, 64, 1, 1),
        "features_extractor.cnn.attention.0.bias": (32,),
        "features_extractor.cnn.attention.2.weight": (1, 32, 1, 1),
        "features_extractor.cnn.attention.2.bias": (1,),
        "features_extractor.reduce.weight": (16, 64, 1, 1),
        "features_extractor.reduce.bias": (16,),
        "features_extractor.vector_net.weight": (64, 3),
        "features_extractor.vector_net.bias": (64,),
        "features_extractor.fuse.weight": (256, 16 * 10 * 15 + 64),
        "features_extractor.fuse.bias": (256,),
    }
    # The network's input: the frames and a helicopter channel on the helicopter's cell (grid
    # row y, as the Rust encoder writes it), all codes / 9.
    obs = vec.reset()
    tensors, _ = model.policy.obs_to_tensor(obs)
    extractor = model.policy.features_extractor
    seen = []
    extractor.cnn.register_forward_pre_hook(lambda _module, args: seen.append(args[0]))
    assert extractor(tensors).shape == (1, 256)
    image = seen[0][0].numpy()
    x, y = obs["helicopter_coord"][0]
    assert image.shape == (5, 160, 240)
    np.testing.assert_allclose(image[:4], obs["cells"][0] / 9.0, rtol=1e-6)
    assert image[4, y, x] == 1.0 and image[4].sum() == 1.0


def test_ppo_trains_a_few_steps_with_the_compact_extractor():
    torch.set_num_threads(1)
    vec = HelitackVecEnv(2, seed=0, **small(max_steps=40))
    model = quiet(
        PPO(
            "MultiInputPolicy",
            vec,
            n_steps=32,
            batch_size=32,
            n_epochs=2,
            seed=0,
            device="cpu",
            policy_kwargs={"features_extractor_class": CompactExtractor},
        )
    )
    before = {k: v.clone() for k, v in model.policy.features_extractor.state_dict().items()}
    model.learn(total_timesteps=128)
    assert model.num_timesteps >= 128
    after = model.policy.features_extractor.state_dict()
    assert any(not torch.equal(before[k], after[k]) for k in before), "PPO moved the CNN"
    assert np.isfinite(model.logger.name_to_value.get("train/value_loss", 0.0))
    # On 48 × 32 the reduction pools to branch a's 4 × 6 grid.
    assert model.policy.features_extractor.pooled == (4, 6)
    actions, _ = model.predict(vec.reset(), deterministic=True)
    assert actions.shape == (2,)
