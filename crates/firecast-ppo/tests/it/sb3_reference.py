"""Golden fixtures from Stable-Baselines3 itself for firecast-ppo's PPO (tests/it/golden.rs).

Usage: python sb3_reference.py OUT.json [CASE ...]   (no CASE, or `all`: every case)

Every case holds its inputs and what SB3 computes from them:

- `loss_*`: a real `PPO("MlpPolicy")` (default pi/vf [64, 64] Tanh, orthogonal init), its
  `state_dict`, a crafted rollout buffer of `n` transitions put into SB3's `RolloutBuffer`
  (n_envs 1, batch_size n, so each epoch is one minibatch in step order: the permutation is
  pinned to the identity), then `model.train()` itself. Exported: the logger's train/* values,
  every minibatch's gradients before and after `clip_grad_norm_` and its total norm, the
  weights after Adam's steps, and torch's Categorical log_prob/entropy on the minibatch.
- `gae_*`: `RolloutBuffer.add` with crafted rewards, values and episode starts, then
  `compute_returns_and_advantage(last_values, dones)`.
- `timeout`: SB3's `collect_rollouts` on a deterministic 3-env `DummyVecEnv` whose episodes
  end by a time limit (bootstrapped from `terminal_observation`), by termination, and by both
  at once; exported: the rollout buffer after GAE.

Floats are float32 values written as JSON numbers (exact as doubles).
"""

import json
import sys

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common import buffers as sb3_buffers
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.vec_env import DummyVecEnv


def flat(t):
    if isinstance(t, th.Tensor):
        t = t.detach().cpu().numpy()
    return [float(x) for x in np.asarray(t, dtype=np.float32).reshape(-1)]


def shape(t):
    return list(t.shape)


class ConstEnv(gym.Env):
    """Observations are drawn once; the dynamics never matter for the loss cases."""

    def __init__(self, obs_dim, n_actions):
        super().__init__()
        self.observation_space = spaces.Box(-10.0, 10.0, (obs_dim,), np.float32)
        self.action_space = spaces.Discrete(n_actions)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(self.observation_space.shape, np.float32), {}

    def step(self, action):
        return np.zeros(self.observation_space.shape, np.float32), 0.0, False, False, {}


# ---------------------------------------------------------------------------------------
# Loss cases

LOSS_CASES = {
    # name: settings
    "loss_clip02_novf_ent0": dict(obs=4, act=2, n=64, seed=1, clip=0.2, clip_vf=None, ent=0.0, vf=0.5, mgn=1e9, epochs=1, action_scale=1.0),
    "loss_clip01_vf_ent02": dict(obs=6, act=5, n=48, seed=2, clip=0.1, clip_vf=0.2, ent=0.2, vf=0.4, mgn=1e9, epochs=1, action_scale=30.0),
    "loss_clip02_vf_ent02_gradclip": dict(obs=4, act=5, n=64, seed=3, clip=0.2, clip_vf=0.1, ent=0.2, vf=0.5, mgn=0.5, epochs=2, action_scale=10.0),
    "loss_clip01_novf_ent0_gradclip": dict(obs=6, act=2, n=32, seed=4, clip=0.1, clip_vf=None, ent=0.0, vf=0.4, mgn=1.0, epochs=3, action_scale=100.0),
    "loss_clip02_novf_ent02_peaked": dict(obs=6, act=5, n=40, seed=5, clip=0.2, clip_vf=None, ent=0.2, vf=0.5, mgn=0.5, epochs=2, action_scale=400.0),
}


def loss_case(name, s):
    th.manual_seed(s["seed"])
    rng = np.random.default_rng(s["seed"])
    n = s["n"]
    env = DummyVecEnv([lambda: ConstEnv(s["obs"], s["act"])])
    model = PPO(
        "MlpPolicy",
        env,
        n_steps=n,
        batch_size=n,
        n_epochs=s["epochs"],
        learning_rate=3e-4,
        clip_range=s["clip"],
        clip_range_vf=s["clip_vf"],
        ent_coef=s["ent"],
        vf_coef=s["vf"],
        max_grad_norm=s["mgn"],
        normalize_advantage=True,
        seed=s["seed"],
        device="cpu",
    )
    policy = model.policy
    with th.no_grad():
        # Sharpen the (0.01-gain) action head so ratios, clipping and entropies are not all
        # trivial; these are the weights both sides start from.
        policy.action_net.weight.mul_(s["action_scale"])
        policy.action_net.bias.copy_(th.linspace(-0.5, 0.5, s["act"]))
    state = {k: v.detach().clone() for k, v in policy.state_dict().items()}

    obs = rng.normal(0.0, 1.5, (n, s["obs"])).astype(np.float32)
    actions = rng.integers(0, s["act"], n)
    obs_t = th.as_tensor(obs)
    act_t = th.as_tensor(actions).long()
    with th.no_grad():
        values, log_prob, entropy = policy.evaluate_actions(obs_t, act_t)
        values = values.flatten()
        dist = th.distributions.Categorical(logits=policy.action_net(policy.mlp_extractor.forward_actor(policy.extract_features(obs_t))))
        cat_logp = dist.log_prob(act_t)
        cat_ent = dist.entropy()
    old_log_probs = (log_prob + th.as_tensor(rng.normal(0.0, 0.3, n).astype(np.float32))).float()
    old_values = (values + th.as_tensor(rng.normal(0.0, 0.3, n).astype(np.float32))).float()
    advantages = (rng.normal(0.3, 2.0, n)).astype(np.float32)
    returns = (old_values.numpy() + rng.normal(0.0, 1.0, n)).astype(np.float32)

    buf = model.rollout_buffer
    buf.reset()
    buf.observations[:, 0] = obs
    buf.actions[:, 0, 0] = actions.astype(np.float32)
    buf.values[:, 0] = old_values.numpy()
    buf.log_probs[:, 0] = old_log_probs.numpy()
    buf.advantages[:, 0] = advantages
    buf.returns[:, 0] = returns
    buf.episode_starts[:, 0] = 0.0
    buf.rewards[:, 0] = 0.0
    buf.pos = n
    buf.full = True
    buf.generator_ready = False

    model.set_logger(Logger(folder=None, output_formats=[]))
    model._current_progress_remaining = 1.0

    records = []
    real_clip = th.nn.utils.clip_grad_norm_

    def recording_clip(params, max_norm, *args, **kwargs):
        params = list(params)
        names = {id(p): k for k, p in policy.named_parameters()}
        raw = {names[id(p)]: flat(p.grad) for p in params if p.grad is not None}
        total = real_clip(params, max_norm, *args, **kwargs)
        clipped = {names[id(p)]: flat(p.grad) for p in params if p.grad is not None}
        records.append(dict(raw_grads=raw, total_norm=float(total), clipped_grads=clipped))
        return total

    real_perm = sb3_buffers.np.random.permutation
    th.nn.utils.clip_grad_norm_ = recording_clip
    sb3_buffers.np.random.permutation = lambda k: np.arange(k)
    try:
        model.train()
    finally:
        th.nn.utils.clip_grad_norm_ = real_clip
        sb3_buffers.np.random.permutation = real_perm
    assert len(records) == s["epochs"], len(records)

    logged = {k: float(v) for k, v in model.logger.name_to_value.items() if k.startswith("train/")}
    after = {k: flat(v) for k, v in policy.state_dict().items()}
    return dict(
        kind="loss",
        settings=dict(s, lr=3e-4, adam_eps=float(policy.optimizer.defaults["eps"])),
        weights={k: dict(shape=shape(v), data=flat(v)) for k, v in state.items()},
        obs=flat(obs),
        actions=[int(a) for a in actions],
        old_values=flat(old_values),
        old_log_probs=flat(old_log_probs),
        advantages=flat(advantages),
        returns=flat(returns),
        values=flat(values),
        log_prob=flat(cat_logp),
        entropy=flat(cat_ent),
        sb3_log_prob=flat(log_prob),
        sb3_entropy=flat(entropy),
        logged=logged,
        steps=records,
        weights_after=after,
    )


# ---------------------------------------------------------------------------------------
# GAE cases

GAE_CASES = {
    "gae_sb3": dict(gamma=0.99, lam=0.95, seed=11),
    "gae_paper": dict(gamma=0.95, lam=0.9, seed=12),
}


def gae_case(name, s):
    rng = np.random.default_rng(s["seed"])
    n_steps, n_envs = 7, 3
    obs_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
    buf = RolloutBuffer(n_steps, obs_space, spaces.Discrete(2), device="cpu", gamma=s["gamma"], gae_lambda=s["lam"], n_envs=n_envs)
    rewards = rng.normal(0.5, 1.0, (n_steps, n_envs)).astype(np.float32)
    values = rng.normal(0.0, 2.0, (n_steps, n_envs)).astype(np.float32)
    starts = np.zeros((n_steps, n_envs), np.float32)
    starts[0, :] = 1.0  # first step of training
    starts[3, 0] = 1.0  # env 0: an episode ended at step 2
    starts[1, 1] = 1.0  # env 1: episodes ended at steps 0 and 4
    starts[5, 1] = 1.0
    starts[6, 2] = 1.0  # env 2: ended at step 5, and its last step is done too
    dones = np.array([False, False, True])
    last_values = th.as_tensor(rng.normal(0.0, 2.0, n_envs).astype(np.float32))
    for t in range(n_steps):
        buf.add(
            np.zeros((n_envs, 1), np.float32),
            np.zeros((n_envs, 1), np.float32),
            rewards[t],
            starts[t],
            th.as_tensor(values[t]),
            th.zeros(n_envs),
        )
    buf.compute_returns_and_advantage(last_values=last_values, dones=dones)
    return dict(
        kind="gae",
        gamma=s["gamma"],
        gae_lambda=s["lam"],
        n_steps=n_steps,
        n_envs=n_envs,
        rewards=flat(rewards),
        values=flat(values),
        episode_starts=flat(starts),
        last_values=flat(last_values),
        dones=[bool(d) for d in dones],
        advantages=flat(buf.advantages),
        returns=flat(buf.returns),
    )


# ---------------------------------------------------------------------------------------
# Time-limit bootstrap through collect_rollouts

# Per env: (terminate after k steps or None, time limit). Env 0 is truncated every 3 steps,
# env 1 terminates and hits its limit on the same (3rd) step (no bootstrap: SB3 sets
# TimeLimit.truncated only when not terminated), env 2 terminates after 2 steps.
TIMEOUT_ENVS = [(None, 3), (3, 3), (2, 5)]


class CountingEnv(gym.Env):
    """Deterministic, action-independent dynamics (mirrored by golden.rs's `CountingVec`):
    obs = [episode/2, t/4, env/8 − 1, t²/16 − 1/2], reward = 1 + t/2 − env/4 (t = steps taken
    in the episode before this one), all exact in float32."""

    def __init__(self, env_id, terminate_after):
        super().__init__()
        self.observation_space = spaces.Box(-100.0, 100.0, (4,), np.float32)
        self.action_space = spaces.Discrete(2)
        self.env_id = env_id
        self.terminate_after = terminate_after
        self.episode = -1
        self.t = 0

    def _obs(self):
        t = self.t
        return np.array([self.episode / 2, t / 4, self.env_id / 8 - 1, t * t / 16 - 0.5], np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.episode += 1
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        reward = 1.0 + self.t / 2 - self.env_id / 4
        self.t += 1
        terminated = self.terminate_after is not None and self.t >= self.terminate_after
        return self._obs(), reward, terminated, False, {}


def timeout_case(name):
    gamma, lam = 0.99, 0.95
    n_steps = 8
    fns = [lambda i=i, term=term, limit=limit: gym.wrappers.TimeLimit(CountingEnv(i, term), limit) for i, (term, limit) in enumerate(TIMEOUT_ENVS)]
    env = DummyVecEnv(fns)
    th.manual_seed(21)
    model = PPO("MlpPolicy", env, n_steps=n_steps, batch_size=8, gamma=gamma, gae_lambda=lam, seed=21, device="cpu")
    model.set_logger(Logger(folder=None, output_formats=[]))
    policy = model.policy
    with th.no_grad():
        # Action 0 always (a logit gap of 100): both sides then take the same actions without
        # sharing a random stream. Value weights scaled so V(terminal) is far from 0.
        policy.action_net.bias.copy_(th.tensor([50.0, -50.0]))
        policy.value_net.weight.mul_(3.0)
        policy.value_net.bias.fill_(0.7)
    state = {k: v.detach().clone() for k, v in policy.state_dict().items()}
    _, callback = model._setup_learn(n_steps * len(TIMEOUT_ENVS), callback=None)
    callback.on_training_start(locals(), globals())

    # The raw rewards and bootstrap values, for the report.
    boot = []
    real_step = env.step_wait

    def step_wait():
        obs, rews, dones, infos = real_step()
        for i, d in enumerate(dones):
            if d and infos[i].get("TimeLimit.truncated", False):
                with th.no_grad():
                    v = policy.predict_values(policy.obs_to_tensor(infos[i]["terminal_observation"])[0])[0]
                boot.append(dict(env=i, terminal_observation=flat(infos[i]["terminal_observation"]), value=float(v)))
        return obs, rews, dones, infos

    env.step_wait = step_wait
    ok = model.collect_rollouts(env, callback, model.rollout_buffer, n_rollout_steps=n_steps)
    assert ok
    buf = model.rollout_buffer
    assert buf.actions.sum() == 0, "the forced action should always be 0"
    return dict(
        kind="timeout",
        gamma=gamma,
        gae_lambda=lam,
        n_steps=n_steps,
        n_envs=len(TIMEOUT_ENVS),
        envs=[[-1 if term is None else term, limit] for term, limit in TIMEOUT_ENVS],
        weights={k: dict(shape=shape(v), data=flat(v)) for k, v in state.items()},
        bootstraps=boot,
        observations=flat(buf.observations),
        actions=[int(a) for a in buf.actions.reshape(-1)],
        rewards=flat(buf.rewards),
        episode_starts=flat(buf.episode_starts),
        values=flat(buf.values),
        log_probs=flat(buf.log_probs),
        advantages=flat(buf.advantages),
        returns=flat(buf.returns),
    )


def main():
    out = sys.argv[1]
    wanted = sys.argv[2:] or ["all"]
    th.set_num_threads(1)
    cases = {}
    everything = "all" in wanted
    for name, s in LOSS_CASES.items():
        if everything or name in wanted:
            cases[name] = loss_case(name, s)
    for name, s in GAE_CASES.items():
        if everything or name in wanted:
            cases[name] = gae_case(name, s)
    if everything or "timeout" in wanted:
        cases["timeout"] = timeout_case("timeout")
    unknown = [w for w in wanted if w != "all" and w not in cases]
    if unknown:
        sys.exit(f"unknown cases: {unknown}")
    import stable_baselines3

    meta = dict(sb3=stable_baselines3.__version__, torch=th.__version__, numpy=np.__version__)
    with open(out, "w") as f:
        json.dump(dict(meta=meta, cases=cases), f)


if __name__ == "__main__":
    main()
