//! Baseline agents and the episode runner.

use firecast_sim::{
    EnvConfig, FireChaser, NoSuppression, Policy, RuleBasedAgent, RuleNavigation, WildfireEnv, record_frames,
    run_episodes,
};

use crate::scenes::modis_rough;

#[test]
fn rule_based_agent_waypoints_and_drop_counts() {
    let land = modis_rough(6);
    let cfg = EnvConfig::default();
    let mut one = RuleBasedAgent::single_circle();
    let report = run_episodes(&land, &cfg, &mut one, 2, 1).unwrap();
    assert_eq!(one.waypoints().len(), 36);
    assert_eq!(one.waypoints()[0], [149, 79], "(int(119 + 30), 79)");
    assert_eq!(one.waypoints()[9], [119, 109]);
    for e in &report.episodes {
        assert_eq!(e.helitacks, 36, "one circle = 36 drops");
        assert_eq!(e.water_used_gal, 36.0 * 800.0);
    }
    let mut three = RuleBasedAgent::concentric_circles();
    let report = run_episodes(&land, &cfg, &mut three, 1, 1).unwrap();
    assert_eq!(three.waypoints().len(), 108);
    assert_eq!(three.waypoints()[0], [164, 79], "outermost (45) first");
    assert_eq!(report.episodes[0].helitacks, 108);
}

#[test]
fn rule_based_burns_fewer_cells_than_no_suppression() {
    let land = modis_rough(6);
    let cfg = EnvConfig::default();
    let none = run_episodes(&land, &cfg, &mut NoSuppression, 6, 1).unwrap();
    let agents: [(&str, Box<dyn Policy>); 3] = [
        ("single", Box::new(RuleBasedAgent::single_circle())),
        ("concentric", Box::new(RuleBasedAgent::concentric_circles())),
        (
            "fly",
            Box::new(RuleBasedAgent::concentric_circles().navigation(RuleNavigation::Fly)),
        ),
    ];
    for (name, mut agent) in agents {
        let rule = run_episodes(&land, &cfg, agent.as_mut(), 6, 1).unwrap();
        println!(
            "{name}: {:.0} ± {:.0} cells vs none {:.0} ± {:.0}",
            rule.cells_burned.mean, rule.cells_burned.std, none.cells_burned.mean, none.cells_burned.std
        );
        for (r, n) in rule.episodes.iter().zip(&none.episodes) {
            assert_eq!(r.seed, n.seed);
            assert!(
                r.cells_burned <= n.cells_burned,
                "{name} seed {}: {} > {}",
                r.seed,
                r.cells_burned,
                n.cells_burned
            );
        }
        assert!(rule.cells_burned.mean < none.cells_burned.mean, "{name}");
        assert!(rule.helitacks.mean > 0.0);
    }
    // Table IV columns are consistent.
    assert_eq!(none.episodes.len(), 6);
    assert_eq!(none.helitacks.mean, 0.0);
    assert!(none.episodes.iter().all(|e| e.terminated && e.timesteps > 100));
    let mean = none
        .episodes
        .iter()
        .map(|e| f64::from(e.cells_burned))
        .sum::<f64>()
        / 6.0;
    assert!((none.cells_burned.mean - mean).abs() < 1e-9);
}

#[test]
fn chaser_flies_to_the_fire_and_burns_fewer_cells() {
    let land = modis_rough(6);
    let cfg = EnvConfig::default();
    let none = run_episodes(&land, &cfg, &mut NoSuppression, 4, 1).unwrap();
    let chaser = run_episodes(&land, &cfg, &mut FireChaser::default(), 4, 1).unwrap();
    println!(
        "chaser: {:.0} cells, {:.0} drops; none {:.0}",
        chaser.cells_burned.mean, chaser.helitacks.mean, none.cells_burned.mean
    );
    assert!(chaser.cells_burned.mean < none.cells_burned.mean);
    assert!(chaser.helitacks.mean > 0.0);
    // It flies: never more than one move (3 cells) per step, no teleport.
    let frames = record_frames(&land, &cfg, &mut FireChaser::default(), 1).unwrap();
    for (a, b) in frames.helicopter.iter().zip(&frames.helicopter[1..]) {
        let moved = (a[0] - b[0]).abs() + (a[1] - b[1]).abs();
        assert!(moved <= 3, "{a:?} -> {b:?}");
    }
    // Every drop lands within reach of a burning cell.
    let w = frames.width as i32;
    let mut drops = 0;
    for (k, (a, b)) in frames.helicopter.iter().zip(&frames.helicopter[1..]).enumerate() {
        if a != b {
            continue;
        }
        let burning_near = frames.fire_states[k].iter().enumerate().any(|(i, &s)| {
            let (x, y) = (i as i32 % w, i as i32 / w);
            s == 1 && (x - a[0]).pow(2) + (y - a[1]).pow(2) <= 16
        });
        drops += u32::from(burning_near);
    }
    assert_eq!(
        drops, frames.stats.helitacks,
        "a drop (standing still) only near flames"
    );
}

#[test]
fn recorded_frames_follow_the_episode() {
    let land = modis_rough(6);
    let cfg = EnvConfig::default();
    let frames = record_frames(&land, &cfg, &mut RuleBasedAgent::single_circle(), 2).unwrap();
    assert_eq!(frames.fire_states.len(), frames.stats.timesteps as usize + 1);
    assert_eq!(frames.helicopter.len(), frames.fire_states.len());
    assert!(frames.fire_states[0].iter().all(|&s| s == 0));
    let last = frames.fire_states.last().unwrap();
    assert_eq!(
        last.iter().filter(|&&s| s != 0).count() as u32,
        frames.stats.cells_burned
    );
    assert!(last.iter().all(|&s| s != 1), "terminated: nothing burning");
    assert_eq!(
        frames.helicopter[1],
        [149, 79],
        "teleported to the first waypoint"
    );
}

/// Single-thread throughput on 240×160 with an active fire (observation included). Prints the
/// rate; asserts only a loose floor so slow CI machines pass.
#[test]
fn throughput_single_thread() {
    let land = modis_rough(6);
    let cfg = EnvConfig::default();
    let mut env = WildfireEnv::new(&land, &cfg).unwrap();
    let actions = [
        firecast_sim::Action::West,
        firecast_sim::Action::Drop,
        firecast_sim::Action::East,
        firecast_sim::Action::South,
        firecast_sim::Action::North,
    ];
    let (mut steps, mut burning_steps, mut burning_sum, mut k) = (0u64, 0u64, 0u64, 0usize);
    env.reset(2);
    let start = std::time::Instant::now();
    while steps < 60_000 {
        let (obs, _, terminated, truncated, info) = env.step(actions[k % 5]);
        std::hint::black_box(obs.frames[k % obs.frames.len()]);
        k = k.wrapping_mul(31).wrapping_add(7) % 1_000_003;
        steps += 1;
        burning_steps += u64::from(info.cells_burning > 0);
        burning_sum += u64::from(info.cells_burning);
        if terminated || truncated {
            env.reset(2);
        }
    }
    let rate = steps as f64 / start.elapsed().as_secs_f64();
    println!(
        "single-thread env steps/s: {rate:.0} ({burning_steps}/{steps} steps with burning cells, {:.0} burning on average)",
        burning_sum as f64 / steps as f64
    );
    assert!(burning_steps * 10 > steps * 9);
    assert!(rate > 2_000.0);
}

/// The rollout algorithm's law (Bertsekas): on a fire without random draws, a search whose
/// copies play to the end of the episode burns no more than its base policy, episode by
/// episode — the base policy's own action is always among those it weighs.
#[test]
fn rollout_search_to_the_end_never_burns_more_than_the_chaser() {
    use firecast_sim::{RolloutSearch, SearchConfig};
    let land = modis_rough(6);
    // Short episodes: the search replays the rest of the episode five times a step.
    let mut cfg = EnvConfig {
        max_steps: 100,
        ..EnvConfig::default()
    };
    cfg.sim.fire_survival_probability = 0.0;
    cfg.sim.latch_daily_probability.clear();
    let search_cfg = SearchConfig {
        horizon: cfg.max_steps,
        burning_weight: 1.0,
        min_gain: 0.0,
        seed: 3,
    };
    let chaser = run_episodes(&land, &cfg, &mut FireChaser::default(), 3, 1).unwrap();
    let mut search = RolloutSearch::over_chaser(search_cfg);
    let searched = run_episodes(&land, &cfg, &mut search, 3, 1).unwrap();
    let mut better = 0;
    for (s, c) in searched.episodes.iter().zip(&chaser.episodes) {
        println!(
            "seed {}: search {} cells, chaser {}",
            s.seed, s.cells_burned, c.cells_burned
        );
        assert!(
            s.cells_burned <= c.cells_burned,
            "seed {}: {} > {}",
            s.seed,
            s.cells_burned,
            c.cells_burned
        );
        better += usize::from(s.cells_burned < c.cells_burned);
    }
    assert!(
        better > 0,
        "the search found nothing better than the chaser on any fire"
    );
    // A gain nothing can reach: every move is the chaser's.
    let mut stubborn = RolloutSearch::over_chaser(SearchConfig {
        min_gain: f64::INFINITY,
        ..search_cfg
    });
    let kept = run_episodes(&land, &cfg, &mut stubborn, 3, 1).unwrap();
    assert_eq!(kept.episodes, chaser.episodes);
    // Without the simulator it is its base policy.
    let mut blind = RolloutSearch::over_chaser(search_cfg);
    let mut env = WildfireEnv::new(&land, &cfg).unwrap();
    let (obs, _) = env.reset(1);
    assert_eq!(blind.act(&obs), FireChaser::default().act(&obs));
}
