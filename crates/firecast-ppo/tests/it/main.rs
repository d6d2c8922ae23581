//! Integration tests of firecast-ppo: CartPole-v1 (the correctness gate, exact resumption)
//! and golden tests against Stable-Baselines3 itself.

mod cartpole;
mod golden;
