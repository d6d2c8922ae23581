//! Integration tests of firecast-rl.

mod ensemble;
mod imitation;
mod recipes;
mod recordings;
mod recurrent;
mod tiny;
