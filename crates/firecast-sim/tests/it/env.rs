//! The helitack environment's contract and the vectorised environment.

use firecast_sim::env::{CODE_MAX, FRAME_STACK};
use firecast_sim::{Action, EnvConfig, FireState, RewardWeights, Termination, VecEnv, WildfireEnv};
use serde::Deserialize;
use serde::de::value::{Error as ValueError, MapDeserializer};

use crate::scenes::modis_rough;

/// Cell codes recomputed from the automaton (0 non-burnable, else state·3 + BI + 1).
fn codes(env: &WildfireEnv) -> Vec<u8> {
    let a = env.automaton();
    (0..a.width() * a.height())
        .map(|i| {
            if a.is_non_burnable(i) {
                0
            } else {
                a.fire_states()[i] * 3 + a.burn_indices()[i] + 1
            }
        })
        .collect()
}

/// A deterministic action stream that drops often near the fire.
fn action(k: usize) -> Action {
    [
        Action::East,
        Action::North,
        Action::Drop,
        Action::South,
        Action::West,
        Action::Drop,
    ][(k * 7 + k / 5) % 6]
}

#[test]
fn observation_shape_bounds_stack_and_on_fire_flag() {
    let land = modis_rough(6);
    let mut env = WildfireEnv::new(&land, &EnvConfig::default()).unwrap();
    let n = 240 * 160;
    let (obs, info) = env.reset(5);
    assert_eq!(obs.frames.len(), FRAME_STACK * n);
    assert_eq!((obs.width, obs.height, obs.agent), (240, 160, [70, 30]));
    assert_eq!((info.step, info.cells_burning, info.drops), (0, 0, 0));
    let initial = codes(&env);
    let mut history = vec![initial.clone(); FRAME_STACK];
    let (mut quenched, mut drops, mut new_burnt) = (0u32, 0u32, 0u32);
    let mut prev_burnt = 0;
    for k in 0..400 {
        // Teleport onto a burning cell now and then to exercise the flag and the drop.
        let target = (k % 9 == 0)
            .then(|| env.automaton().burning_cells().first().copied())
            .flatten();
        let teleport = target.map(|c| [(c % 240) as i32, (c / 240) as i32]);
        let act = if teleport.is_some() {
            Action::Drop
        } else {
            action(k)
        };
        let (obs, _reward, terminated, truncated, info) = env.step_with_teleport(act, teleport);
        assert!(obs.frames.iter().all(|&c| c <= CODE_MAX));
        let [x, y] = obs.agent;
        assert!((0..240).contains(&x) && (0..160).contains(&y));
        let i = y as usize * 240 + x as usize;
        assert_eq!(obs.on_fire, env.automaton().fire_state(i) == FireState::Burning);
        // Frame stack: oldest first, newest = the current state.
        history.remove(0);
        history.push(codes(&env));
        for (slot, frame) in history.iter().enumerate() {
            assert!(
                env.observation().frames[slot * n..(slot + 1) * n] == frame[..],
                "slot {slot} at step {k}"
            );
        }
        // Info counters.
        drops += u32::from(act == Action::Drop);
        quenched += info.quenched_step;
        new_burnt += info.new_burnt;
        assert_eq!(info.step, k as u32 + 1);
        assert_eq!(info.drops, drops);
        assert_eq!(info.cells_quenched, quenched);
        assert_eq!(info.water_used_gal, 800.0 * f64::from(drops));
        assert_eq!(info.cells_burnt, new_burnt);
        assert!(info.cells_burnt >= prev_burnt);
        prev_burnt = info.cells_burnt;
        assert_eq!(info.cells_burning, env.automaton().burning_cells().len() as u32);
        assert!((info.sim_time_min - 11.9664 * (k + 1) as f64).abs() < 1e-6);
        if terminated || truncated {
            break;
        }
    }
    assert!(
        quenched > 0,
        "teleported drops onto burning cells must quench some"
    );
}

#[test]
fn terminates_when_nothing_burns_and_truncates_at_max_steps() {
    let land = modis_rough(6);
    let mut env = WildfireEnv::new(&land, &EnvConfig::default()).unwrap();
    env.reset(1);
    let mut steps = 0;
    loop {
        let (_, _, terminated, truncated, info) = env.step(Action::West);
        steps += 1;
        assert!(!truncated);
        if terminated {
            assert_eq!(info.cells_burning, 0);
            assert!(env.automaton().fire_out());
            assert!(info.cells_burnt > 100);
            break;
        }
        assert!(info.cells_burning > 0 || !env.automaton().fire_out());
    }
    // A11: the unsuppressed fire dies by itself (latch) well before 2000 steps.
    assert!(steps < 2000, "{steps}");

    let cfg = EnvConfig {
        max_steps: 7,
        ..EnvConfig::default()
    };
    let mut env = WildfireEnv::new(&land, &cfg).unwrap();
    env.reset(1);
    for k in 1..=7 {
        let (_, _, terminated, truncated, info) = env.step(Action::South);
        assert!(!terminated);
        assert_eq!(truncated, k == 7, "step {k}");
        assert_eq!(info.cells_burning, 1, "the spark burns for the first steps");
    }

    // NoBurningCells termination: quenching the only burning cell ends the episode at once.
    let cfg = EnvConfig {
        termination: Termination::NoBurningCells,
        ignition: Some([100, 100]),
        helicopter_start: Some([100, 100]),
        ..EnvConfig::default()
    };
    let mut env = WildfireEnv::new(&land, &cfg).unwrap();
    env.reset(3);
    let (obs, _, terminated, _, _) = env.step(Action::South);
    assert!(!terminated);
    assert!(!obs.on_fire, "the helicopter moved off the spark");
    let (_, reward, terminated, _, info) = env.step_with_teleport(Action::Drop, Some([100, 100]));
    assert_eq!(info.quenched_step, 1);
    assert!(terminated);
    assert!(
        (reward - (5.0 - 0.01)).abs() < 1e-9,
        "P2 reward: +5 per quenched cell − 0.01, got {reward}"
    );
}

#[test]
fn reward_presets_and_config_deserialisation() {
    assert_eq!(RewardWeights::default(), RewardWeights::p2());
    assert_eq!(
        RewardWeights::preset("websocket_t"),
        Some(RewardWeights::websocket_t())
    );
    assert!(RewardWeights::preset("nope").is_none());
    let de = MapDeserializer::<_, ValueError>::new(vec![("quenched", 1.5), ("step", -1.0)].into_iter());
    let rw = RewardWeights::deserialize(de).unwrap();
    assert_eq!((rw.quenched, rw.step, rw.burning), (1.5, -1.0, -0.05));
    let de = MapDeserializer::<_, ValueError>::new(vec![("quenchd", 1.0)].into_iter());
    assert!(
        RewardWeights::deserialize(de).is_err(),
        "unknown fields must be rejected"
    );
    let de = MapDeserializer::<_, ValueError>::new(vec![("max_steps", 10u32)].into_iter());
    assert_eq!(EnvConfig::deserialize(de).unwrap().max_steps, 10);

    // T preset: a drop on an unburnt cell far from any fire costs −10; the step cost −0.1.
    let land = modis_rough(6);
    let cfg = EnvConfig {
        reward: RewardWeights::websocket_t(),
        ..EnvConfig::default()
    };
    let mut env = WildfireEnv::new(&land, &cfg).unwrap();
    env.reset(0);
    let (_, r, ..) = env.step(Action::Drop);
    // −10 drop, −0.1 step, −0.1·1 burning, proximity 2·exp(−d/20) with d = |(70,30)−(119,79)|.
    let d = (49f64 * 49.0 * 2.0).sqrt();
    assert!(
        (r - (-10.0 - 0.1 - 0.1 + 2.0 * (-d / 20.0).exp())).abs() < 1e-9,
        "{r}"
    );
}

/// `approach` is the potential −d: a step's shaping is the distance to the nearest flames
/// before minus after, whatever moved (the helicopter or the fire); with nothing burning it is
/// 0. `suppression` adds it to +1 per quenched cell.
#[test]
fn approach_shaping_is_the_change_in_distance_to_the_flames() {
    let land = modis_rough(6);
    let only_approach = RewardWeights {
        quenched: 0.0,
        burning: 0.0,
        step: 0.0,
        drop_burnt: 0.0,
        drop_non_burnable: None,
        clip: None,
        approach: 1.0,
        ..RewardWeights::p2()
    };
    let nearest = |env: &WildfireEnv| {
        let [hx, hy] = env.core().helicopter();
        let w = env.automaton().width() as i64;
        env.automaton()
            .burning_cells()
            .iter()
            .map(|&c| {
                let (x, y) = (i64::from(c) % w, i64::from(c) / w);
                (((x - i64::from(hx)).pow(2) + (y - i64::from(hy)).pow(2)) as f64).sqrt()
            })
            .min_by(f64::total_cmp)
    };
    for (weights, suppression) in [(only_approach, false), (RewardWeights::suppression(), true)] {
        let cfg = EnvConfig {
            reward: weights,
            ..EnvConfig::default()
        };
        let mut env = WildfireEnv::new(&land, &cfg).unwrap();
        env.reset(3);
        let (mut closer, mut quenched) = (0, 0);
        for k in 0..400 {
            let before = nearest(&env);
            // Fly towards the ignition, then drop on it.
            let a = if k < 16 {
                Action::East
            } else if k < 32 {
                Action::North
            } else {
                Action::Drop
            };
            let (_, r, terminated, truncated, info) = env.step(a);
            let after = nearest(&env);
            let shaping = match (before, after) {
                (Some(b), Some(d)) => b - d,
                _ => 0.0,
            };
            let want = if suppression {
                shaping + f64::from(info.quenched_step)
            } else {
                shaping
            };
            assert!((r - want).abs() < 1e-9, "step {k}: {r} vs {want}");
            closer += usize::from(shaping > 0.0);
            quenched += info.quenched_step;
            if terminated || truncated {
                break;
            }
        }
        assert!(closer > 10, "the helicopter flew towards the fire: {closer}");
        if suppression {
            assert!(quenched > 0, "the drops reached the fire");
        }
    }
}

#[test]
fn drop_cooldown_blocks_drops() {
    let land = modis_rough(6);
    let cfg = EnvConfig {
        drop_cooldown_min: 240.0,
        ..EnvConfig::default()
    };
    let mut env = WildfireEnv::new(&land, &cfg).unwrap();
    env.reset(0);
    let mut last = 0;
    for _ in 0..45 {
        last = env.step(Action::Drop).4.drops;
    }
    // Drops at t = 0, 239.3 (< 240, refused) … every 21 steps (251.3 min): steps 1, 22, 43.
    assert_eq!(last, 3);
}

#[test]
fn vec_env_matches_single_envs_and_auto_resets() {
    let land = modis_rough(6);
    let cfg = EnvConfig {
        max_steps: 50,
        ..EnvConfig::default()
    };
    let mut v = VecEnv::new(&land, &cfg, 3, 9).unwrap();
    let len = v.obs_len();
    assert_eq!(v.frames().len(), 3 * len);
    assert!(v.step(&[Action::Drop]).is_err(), "wrong action count");
    for k in 0..50 {
        let actions = [Action::Drop, Action::West, [Action::South, Action::East][k % 2]];
        v.step(&actions).unwrap();
        for i in 0..3 {
            let a = v.envs()[i].automaton();
            let frames = &v.frames()[i * len..(i + 1) * len];
            let cur = &frames[(FRAME_STACK - 1) * len / FRAME_STACK..];
            let ok = (0..a.width() * a.height()).all(|c| {
                let code = if a.is_non_burnable(c) {
                    0
                } else {
                    a.fire_states()[c] * 3 + a.burn_indices()[c] + 1
                };
                cur[c] == code
            });
            assert!(ok, "env {i} frame out of sync at step {k}");
            assert_eq!(v.agent_positions()[2 * i..2 * i + 2], v.envs()[i].helicopter());
            assert!(v.frames().iter().all(|&c| c <= CODE_MAX));
        }
    }
    // All truncated at step 50 and reset in the same call: final infos kept, fresh frames.
    assert!(v.truncated().iter().all(|&t| t));
    assert!(v.infos().iter().all(|i| i.step == 50));
    assert_eq!(v.infos()[0].drops, 50);
    assert_eq!(v.infos()[0].water_used_gal, 40_000.0);
    for i in 0..3 {
        assert_eq!(v.envs()[i].automaton().cells_burning(), 0);
        assert_eq!(v.envs()[i].automaton().time_min(), 0.0);
        assert_eq!(v.agent_positions()[2 * i..2 * i + 2], [70, 30]);
        assert!(
            v.frames()[i * len..(i + 1) * len].iter().all(|&c| c == 1),
            "all unburnt, low BI"
        );
    }
}

/// The environments of a VecEnv share one spread-rate cache, filled concurrently; the fires
/// must not depend on how many threads fill it, or in what order.
#[test]
fn vec_env_fires_do_not_depend_on_the_thread_count() {
    let land = modis_rough(11);
    let cfg = firecast_sim::bench::large_fire_config();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut v = VecEnv::new(&land, &cfg, 5, 3).unwrap();
            for k in 0..150 {
                let actions: Vec<Action> = (0..5)
                    .map(|i| firecast_sim::bench::ACTIONS[(k + i) % 8])
                    .collect();
                v.step(&actions).unwrap();
            }
            v.envs()
                .iter()
                .map(|e| e.automaton().fire_states().to_vec())
                .collect::<Vec<_>>()
        })
    };
    let one = run(1);
    assert!(
        one.iter().any(|s| s.iter().filter(|&&c| c != 0).count() > 50),
        "fires grew"
    );
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}
