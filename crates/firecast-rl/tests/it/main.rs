//! Integration tests of firecast-rl.

mod cartpole;
mod ensemble;
mod golden;
mod imitation;
mod recordings;
mod recurrent;
mod tiny;
