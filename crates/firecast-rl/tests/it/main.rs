//! Integration tests of firecast-rl.

mod cartpole;
mod golden;
