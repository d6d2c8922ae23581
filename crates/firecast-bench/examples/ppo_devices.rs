//! FireCast's PPO on every device libtorch sees, on one machine, so CPU and CUDA are timed
//! side by side:
//!
//! 1. the correctness gate on each device: RL-Zoo's CartPole-v1 settings, mean of the last
//!    100 training episodes after 100,000 steps (≥ 475 is the gate the CPU tests hold);
//! 2. steps per second of rollouts (environment + inference) and of training (rollouts and
//!    updates, as SB3's `time/fps`) for the compact policy on the demo's fires (96 × 64) and
//!    on FireCastRL-sized fires (240 × 160), the recurrent compact policy (`memory: lstm`) on
//!    the demo's fires, and for the authors' policy on 240 × 160 — with
//!    a small rollout every device can afford, and with the paper's own settings on CUDA.
//!
//! ```text
//! cargo run --release -p firecast-bench --example ppo_devices -- \
//!     [--threads N] [--steps N] [--cartpole-seeds N] [--case NAME-PART] [--json FILE]
//! ```
//!
//! libtorch's CUDA backend comes from the torch wheel's folder (the binary's RUNPATH or
//! `LD_LIBRARY_PATH`); without a GPU only the CPU rows are printed.

use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

use firecast_bench::ppo::phases as bench;
use firecast_ppo::cartpole::CartPoleVec;
use firecast_ppo::ppo::PpoConfig;
use firecast_ppo::train::{NoSink, Trainer};
use firecast_rl::policy::{Memory, PolicyConfig, PolicyKind, View};
use firecast_rl::pool::HelitackPool;
use firecast_rl::{Device, RlError};

struct Args {
    threads: usize,
    steps: u64,
    cartpole_seeds: u64,
    /// Only the speed cases whose name contains this.
    case: Option<String>,
    json: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        threads: std::thread::available_parallelism().map_or(1, std::num::NonZero::get),
        steps: 8192,
        cartpole_seeds: 3,
        case: None,
        json: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--threads" => args.threads = value()?.parse().map_err(|e| format!("--threads: {e}"))?,
            "--steps" => args.steps = value()?.parse().map_err(|e| format!("--steps: {e}"))?,
            "--cartpole-seeds" => {
                args.cartpole_seeds = value()?.parse().map_err(|e| format!("--cartpole-seeds: {e}"))?;
            }
            "--case" => args.case = Some(value()?),
            "--json" => args.json = Some(value()?),
            other => return Err(format!("unknown argument `{other}`")),
        }
    }
    firecast_learn::check_threads(args.threads).map_err(|e| format!("--threads: {e}"))?;
    Ok(args)
}

fn device_name(d: Device) -> String {
    match d {
        Device::Cpu => "cpu".into(),
        Device::Cuda(i) => format!("cuda:{i}"),
        other => format!("{other:?}"),
    }
}

/// The CartPole gate on `device`: (mean of the last 100 training episodes, seconds) per seed.
fn cartpole_gate(device: Device, seeds: u64) -> Result<Vec<(u64, f64, f64)>, RlError> {
    let mlp = PolicyConfig {
        kind: PolicyKind::Mlp,
        ..PolicyConfig::default()
    };
    (0..seeds)
        .map(|seed| {
            let ppo = PpoConfig::cartpole_zoo();
            let env = Box::new(CartPoleVec::new(ppo.n_envs, seed));
            let t = Instant::now();
            let mut trainer = Trainer::new(ppo, &mlp, env, seed, device)?;
            trainer.learn(&NoSink, None)?;
            let secs = t.elapsed().as_secs_f64();
            let last: Vec<f64> = trainer
                .all_episodes
                .iter()
                .rev()
                .take(100)
                .map(|e| e.reward)
                .collect();
            let mean = last.iter().sum::<f64>() / last.len().max(1) as f64;
            Ok((seed, mean, secs))
        })
        .collect()
}

struct Case {
    name: &'static str,
    policy: PolicyConfig,
    width: usize,
    height: usize,
    ppo: PpoConfig,
    steps: u64,
    cuda_only: bool,
}

fn cases(steps: u64) -> Vec<Case> {
    let compact = PolicyConfig {
        kind: PolicyKind::Compact,
        view: View::Helicopter,
        ..PolicyConfig::default()
    };
    let paper_policy = PolicyConfig {
        kind: PolicyKind::Paper,
        ..PolicyConfig::default()
    };
    // Small enough for a CPU: 8 envs × 16 steps, one epoch of two minibatches of 64.
    let small = PpoConfig {
        n_steps: 16,
        n_epochs: 1,
        ..PpoConfig::paper()
    };
    vec![
        Case {
            name: "compact, demo fires 96x64, paper settings",
            policy: compact.clone(),
            width: 96,
            height: 64,
            ppo: PpoConfig::paper(),
            steps,
            cuda_only: false,
        },
        Case {
            name: "compact lstm, demo fires 96x64, paper settings",
            policy: PolicyConfig {
                memory: Memory::Lstm,
                ..compact.clone()
            },
            width: 96,
            height: 64,
            ppo: PpoConfig::paper(),
            steps,
            cuda_only: false,
        },
        Case {
            name: "compact, 240x160, paper settings",
            policy: compact,
            width: 240,
            height: 160,
            ppo: PpoConfig::paper(),
            steps: (steps / 2).max(1024),
            cuda_only: false,
        },
        Case {
            name: "paper policy, 240x160, 8 envs x 16 steps, 1 epoch",
            policy: paper_policy.clone(),
            width: 240,
            height: 160,
            ppo: small,
            steps: 256,
            cuda_only: false,
        },
        Case {
            name: "paper policy, 240x160, paper settings",
            policy: paper_policy,
            width: 240,
            height: 160,
            ppo: PpoConfig::paper(),
            steps: 2048,
            cuda_only: true,
        },
    ]
}

fn run() -> Result<serde_json::Value, Box<dyn std::error::Error>> {
    let args = parse_args()?;
    let info = firecast_learn::torch_info();
    firecast_learn::set_threads(args.threads);
    println!(
        "libtorch: CUDA backend loaded {}, CUDA available {} ({} devices), cuDNN {}; {} CPU threads",
        info.cuda_backend_loaded,
        info.cuda_available,
        info.cuda_device_count,
        info.cudnn_available,
        args.threads
    );
    let mut devices = vec![Device::Cpu];
    if info.cuda_available {
        devices.push(Device::Cuda(0));
    }
    let mut report = serde_json::json!({"torch": info, "threads": args.threads, "cartpole": [], "speed": []});

    // CUDA first: a failure there is the news.
    for &device in devices.iter().rev() {
        let gate = match cartpole_gate(device, args.cartpole_seeds) {
            Ok(gate) => gate,
            Err(e) => {
                println!("CartPole-v1 on {}: error: {e}", device_name(device));
                continue;
            }
        };
        for (seed, mean, secs) in gate {
            println!(
                "CartPole-v1 on {}: seed {seed}, last 100 training episodes {mean:.1} ({}), {secs:.1} s",
                device_name(device),
                if mean >= 475.0 { "gate met" } else { "gate NOT met" }
            );
            std::io::stdout().flush()?;
            if let Some(a) = report["cartpole"].as_array_mut() {
                a.push(serde_json::json!({"device": device_name(device), "seed": seed, "mean_last_100": mean, "seconds": secs}));
            }
        }
    }

    println!(
        "\n{:<52} {:>7} {:>12} {:>12} {:>12}",
        "case", "device", "rollout/s", "train/s", "vs cpu"
    );
    for case in cases(args.steps) {
        if args
            .case
            .as_ref()
            .is_some_and(|c| !case.name.contains(c.as_str()))
        {
            continue;
        }
        let pool = HelitackPool::sized(case.width, case.height)?;
        let fires = pool.fires()?;
        let mut cpu_train = None;
        for &device in &devices {
            if case.cuda_only && device == Device::Cpu {
                continue;
            }
            let run = match bench::helitack(&fires, &case.ppo, &case.policy, case.steps, 0, device) {
                Ok(run) => run,
                Err(e) => {
                    println!("{:<52} {:>7} error: {e}", case.name, device_name(device));
                    continue;
                }
            };
            let s = run.speeds;
            if device == Device::Cpu {
                cpu_train = Some(s.train_sps);
            }
            let ratio = cpu_train.map_or_else(|| "-".to_string(), |c| format!("{:.1}x", s.train_sps / c));
            println!(
                "{:<52} {:>7} {:>12.1} {:>12.1} {:>12}",
                case.name,
                device_name(device),
                s.rollout_sps,
                s.train_sps,
                ratio
            );
            std::io::stdout().flush()?;
            if let Some(a) = report["speed"].as_array_mut() {
                a.push(serde_json::json!({
                    "case": case.name, "device": device_name(device), "steps": case.steps,
                    "parameters": run.parameters, "env_sps": s.env_sps,
                    "rollout_sps": s.rollout_sps, "train_sps": s.train_sps,
                }));
            }
        }
    }
    if let Some(path) = &args.json {
        std::fs::write(path, serde_json::to_vec_pretty(&report)?).map_err(|e| format!("{path}: {e}"))?;
    }
    Ok(report)
}

fn main() -> ExitCode {
    match run() {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
