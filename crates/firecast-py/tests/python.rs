//! The Python package `firecast` (this crate, installed into `.venv` by `cargo xtask setup`)
//! under Gymnasium's and Stable-Baselines3's checkers, SB3's PPO and parity tests: its
//! pytest suite (`tests/python/`) runs with the project's venv. First this test plays fixed
//! episodes with the Rust `WildfireEnv` and `VecEnv` directly and writes them to a fixture
//! that the Python side must reproduce exactly (`FIRECAST_PY_FIXTURE`).
//!
//! A venv without the package fails the test (it never skips): run `cargo xtask setup`.

use std::path::PathBuf;
use std::process::Command;

use firecast_landscape::procedural::{ProceduralOptions, generate};
use firecast_sim::{Action, EnvConfig, VecEnv, WildfireEnv};
use serde_json::{Value, json};

/// The venv's Python, where `cargo xtask setup` installed the `firecast` wheel.
fn python() -> PathBuf {
    firecast_testkit::python()
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Deterministic action draws (a 64-bit LCG), the same on every platform.
struct Actions(u64);
impl Actions {
    fn next(&mut self) -> u8 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 33) % 5) as u8
    }
}

fn action(a: u8) -> Action {
    Action::ALL[usize::from(a)]
}

/// Plays one single-environment episode and a VecEnv stream; returns the fixture.
fn fixture() -> Value {
    let landscape = json!({"procedural": {"seed": 3, "width": 48, "height": 32}});
    // Two-hour steps with a 50 % daily latch: from step 12 the episode seed matters.
    let config = json!({
        "max_steps": 15,
        "sim": {
            "dt_min": 120.0,
            "wind": {"speed_mph": 10.0, "from_direction_deg": 270.0},
            "latch_daily_probability": [0.5, 0.5, 0.5],
        },
        "reward": {"proximity": 2.0, "drop_unburnt_per_nearby": 1.0},
    });
    let land = generate(&ProceduralOptions {
        width: 48,
        height: 32,
        ..ProceduralOptions::with_seed(3)
    })
    .expect("procedural landscape");
    let cfg: EnvConfig = serde_json::from_value(config.clone()).expect("fixture config");
    let mut draws = Actions(7);

    let episode_seed = 12_345u64;
    let mut env = WildfireEnv::new(&land, &cfg).expect("WildfireEnv");
    let (o, _) = env.reset(episode_seed);
    let reset = json!({"cells": hex(o.frames), "agent": o.agent, "on_fire": o.on_fire});
    let (mut actions, mut steps) = (Vec::new(), Vec::new());
    loop {
        let a = draws.next();
        actions.push(a);
        let (o, r, te, tr, info) = env.step(action(a));
        steps.push(json!({
            "cells": hex(o.frames), "agent": o.agent, "on_fire": o.on_fire,
            "reward": r, "terminated": te, "truncated": tr,
            "cells_burning": info.cells_burning, "cells_burnt": info.cells_burnt,
        }));
        if te || tr {
            break;
        }
    }
    let single = json!({"episode_seed": episode_seed, "reset": reset, "actions": actions, "steps": steps});

    let (n, seed) = (3usize, 99u64);
    let mut vec = VecEnv::new(&land, &cfg, n, seed).expect("VecEnv");
    let reset = json!({
        "cells": hex(vec.frames()), "agent": vec.agent_positions(), "on_fire": vec.on_fire(),
    });
    let (mut actions, mut steps) = (Vec::new(), Vec::new());
    for _ in 0..30 {
        let a: Vec<u8> = (0..n).map(|_| draws.next()).collect();
        let acts: Vec<Action> = a.iter().map(|&x| action(x)).collect();
        vec.step(&acts).expect("VecEnv step");
        let terminal: Vec<Value> = (0..n)
            .filter(|&i| vec.terminated()[i] || vec.truncated()[i])
            .map(|i| {
                let (frames, agent, on_fire) = vec.terminal_observation(i);
                json!({"env": i, "cells": hex(frames), "agent": agent, "on_fire": on_fire})
            })
            .collect();
        steps.push(json!({
            "cells": hex(vec.frames()), "agent": vec.agent_positions(), "on_fire": vec.on_fire(),
            "rewards": vec.rewards(), "terminated": vec.terminated(), "truncated": vec.truncated(),
            "terminal": terminal,
        }));
        actions.push(a);
    }
    let vector = json!({"num_envs": n, "seed": seed, "reset": reset, "actions": actions, "steps": steps});
    json!({"landscape": landscape, "config": config, "single": single, "vec": vector})
}

#[test]
fn python_package_passes_its_pytest_suite() {
    let py = python();
    assert!(
        py.exists(),
        "no Python at {}: run `cargo xtask setup` (it creates .venv and installs the firecast package)",
        py.display()
    );
    let probe = Command::new(&py)
        .args(["-c", "import firecast, pytest, stable_baselines3"])
        .output()
        .expect("run python");
    assert!(
        probe.status.success(),
        "{} cannot import firecast, pytest and stable_baselines3: run `cargo xtask setup` (it builds \
         crates/firecast-py with maturin and installs the wheel):\n{}",
        py.display(),
        String::from_utf8_lossy(&probe.stderr)
    );

    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("firecast-py");
    std::fs::create_dir_all(&dir).expect("fixture folder");
    let path = dir.join("rust-streams.json");
    std::fs::write(&path, serde_json::to_vec(&fixture()).expect("fixture JSON")).expect("write fixture");

    let out = Command::new(&py)
        .current_dir(
            std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
        )
        .args([
            "-m",
            "pytest",
            "-q",
            "-rA",
            "-p",
            "no:cacheprovider",
            "tests/python",
        ])
        .env("FIRECAST_PY_FIXTURE", &path)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .expect("run pytest");
    println!("{}", String::from_utf8_lossy(&out.stdout));
    eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        out.status.success(),
        "pytest failed ({}); its output is above",
        out.status
    );
}
