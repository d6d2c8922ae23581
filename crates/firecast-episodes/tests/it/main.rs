//! Episodes end to end: numbers, GIF, Rerun recording, determinism, scenario strictness.
#![allow(clippy::unwrap_used)]

mod behavior_png;
mod landfire;

use std::path::Path;

use firecast_episodes::{AgentKind, EpisodeError, LandscapeSpec, Outputs, Scenario, WeatherSpec};

fn scenario() -> Scenario {
    let mut env = firecast_sim::EnvConfig::default();
    env.sim.wind.speed_mph = 10.0;
    env.sim.wind.from_direction_deg = 250.0;
    env.max_steps = 400;
    Scenario::new(
        LandscapeSpec::Procedural {
            seed: 3,
            width: 120,
            height: 80,
            center: None,
        },
        env,
    )
}

#[test]
fn rule_agent_runs_with_gif_and_a_readable_recording() {
    let dir = tempfile::tempdir().unwrap();
    let s = scenario();
    let land = s.landscape.load(dir.path()).unwrap();
    let outputs = Outputs {
        frames_dir: Some(dir.path().join("frames")),
        gif: Some(dir.path().join("fire.gif")),
        recording: Some(dir.path().join("fire.rrd")),
        frame_every: 10,
    };
    let mut seen = 0;
    let summary = firecast_episodes::run(&s, &land, AgentKind::Rule, 2, 5, &outputs, |_| seen += 1).unwrap();
    assert_eq!(seen, 2);
    assert_eq!(summary.report.episodes.len(), 2);
    assert_eq!(summary.report.episodes[0].seed, 5);
    let first = summary.report.episodes[0];
    assert!(first.helitacks > 0, "the rule agent drops water");
    assert!((first.water_used_gal - 800.0 * f64::from(first.helitacks)).abs() < 1e-9);

    let frames = std::fs::read_dir(dir.path().join("frames")).unwrap().count();
    assert!(
        frames >= (first.timesteps as usize) / 10,
        "{frames} frames for {} steps",
        first.timesteps
    );
    let gif = std::fs::read(dir.path().join("fire.gif")).unwrap();
    assert_eq!(&gif[..6], b"GIF89a");

    let rerun = std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("../../.venv/bin/rerun");
    let out = std::process::Command::new(&rerun)
        .args(["rrd", "print"])
        .arg(dir.path().join("fire.rrd"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    for entity in ["env/fire", "env/terrain", "env/helicopter", "stats/cells_burning"] {
        assert!(text.contains(entity), "recording lacks {entity}");
    }
    // No temporary files left next to the outputs.
    let leftovers: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn same_seed_same_numbers_and_suppression_helps() {
    let dir = tempfile::tempdir().unwrap();
    let s = scenario();
    let land = s.landscape.load(dir.path()).unwrap();
    let run = |agent| {
        firecast_episodes::run(&s, &land, agent, 3, 11, &Outputs::default(), |_| {})
            .unwrap()
            .report
    };
    let rule = run(AgentKind::Rule);
    assert_eq!(rule, run(AgentKind::Rule), "same seed, same episodes");
    let none = run(AgentKind::None);
    assert!(none.helitacks.mean == 0.0);
    assert!(
        rule.cells_burned.mean <= none.cells_burned.mean,
        "rule {} vs none {}",
        rule.cells_burned.mean,
        none.cells_burned.mean
    );
}

#[test]
fn scenario_files_are_strict() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scenario.yaml");
    std::fs::write(
        &path,
        "landscape:\n  procedural: {seed: 1}\nenv:\n  sim:\n    wind: {speed_mph: 5, from_deg: 90}\n",
    )
    .unwrap();
    let err = Scenario::from_file(&path).unwrap_err().to_string();
    assert!(
        err.contains(":5:") && err.contains("unknown field `from_deg`"),
        "{err}"
    );
    std::fs::write(
        &path,
        "landscape:\n  procedural: {seed: 1}\nenv:\n  sim:\n    wind: {speed_mph: 5, from_direction_deg: 90}\n",
    )
    .unwrap();
    let s = Scenario::from_file(&path).unwrap();
    assert_eq!(s.env.sim.wind.from_direction_deg, 90.0);
    assert!("procedural:x".parse::<LandscapeSpec>().is_err());
    assert!("firecastrl:a.png".parse::<LandscapeSpec>().is_err());
    let _ = Path::new(".");
}

fn wind_fixtures() -> std::path::PathBuf {
    // Run-time value first: the compiled-in one may name another clone sharing the target dir.
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("tests/fixtures/gridmet")
}

fn with_weather(date: &str) -> Scenario {
    let mut s = scenario();
    s.weather = Some(WeatherSpec::gridmet_wind(wind_fixtures(), date));
    s
}

/// The day's 10-m wind at the GRIDMET cell nearest the landscape's centre (37.5N 119.5W →
/// lat index 1, lon index 0 of the netCDF4-written fixture), in mi/h, as a 10-m wind.
#[test]
fn weather_from_gridmet_sets_a_ten_metre_wind() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = with_weather("2020-07-04");
    let (land, weather) = s.prepare(dir.path()).unwrap();
    let w = weather.unwrap();
    // Day of year 186: vs = 1 + (186 % 50) / 10 + 1 + 0 = 5.6 m/s; th = (7·186 + 10) % 360 = 232.
    assert!((w.vs_m_s - 5.6).abs() < 1e-5, "{}", w.vs_m_s);
    assert_eq!(w.th_deg, 232.0);
    assert!((w.lat - 37.483_333).abs() < 1e-5 && (w.lon + 119.516_667).abs() < 1e-5);
    assert_eq!(s.env.sim.wind.measured_at, firecast_sim::WindHeight::TenMetre);
    assert!((s.env.sim.wind.speed_mph - 5.6 * 2.236_936).abs() < 1e-4);
    assert_eq!(s.env.sim.wind.from_direction_deg, 232.0);
    // And the episode runs under it, reporting the wind it used.
    let summary =
        firecast_episodes::run(&s, &land, AgentKind::None, 1, 0, &Outputs::default(), |_| {}).unwrap();
    assert_eq!(summary.wind_from_deg, 232.0);
}

/// The day's fuel moisture (docs/spec/fire-model.md §B12) from the netCDF4-written fixture's
/// formulas at lat index 1, lon index 0 (make_wind.py), and the Rothermel kernel set to it.
#[test]
fn the_days_fuel_moisture_comes_from_gridmet_and_reaches_the_kernel() {
    use firecast_sim::moisture;
    let dir = tempfile::tempdir().unwrap();
    let mut s = scenario();
    s.env.sim.kernel = firecast_sim::KernelConfig::rothermel_default();
    s.weather = Some(WeatherSpec::Gridmet {
        dir: wind_fixtures(),
        date: "2020-07-15".into(),
        fuel_moisture: true,
        sky: Default::default(),
    });
    let (_, weather) = s.prepare(dir.path()).unwrap();
    let m = weather.unwrap().fuel_moisture.expect("the day's moisture");
    // Day of year 197: tmmx = 295 + 7 + 1 K, rmin = 8 + 17 %, fm100 = 4 + 8.5, fm1000 = 7 + 8.5.
    let temp_f = (303.0 - 273.15) * 1.8 + 32.0;
    assert!(
        (m.max_temperature_f - temp_f).abs() < 1e-3,
        "{}",
        m.max_temperature_f
    );
    assert!((m.min_humidity_pct - 25.0).abs() < 1e-4);
    let (d1, d10) = moisture::fine_dead_moisture_pct(temp_f, 25.0, moisture::StateOfWeather::Clear);
    assert!((m.dead_1h_pct - d1).abs() < 1e-3 && (m.dead_10h_pct - d10).abs() < 1e-3);
    assert!((m.dead_100h_pct - 12.5).abs() < 1e-4 && (m.dead_1000h_pct - 15.5).abs() < 1e-4);
    // GSI over days 177..=197 at the landscape centre's latitude (37.5).
    let gsi: f64 = (177..=197u32)
        .map(|t| {
            let tmin_c = 268.0 + f64::from(t / 2) / 10.0 - 273.15;
            let vpd_pa = (0.5 + f64::from(t % 7) / 10.0) * 1000.0;
            moisture::growing_season_index(tmin_c, vpd_pa, moisture::day_length_s(37.5, t))
        })
        .sum::<f64>()
        / 21.0;
    assert!((m.gsi_21d - gsi).abs() < 1e-4, "{} vs {gsi}", m.gsi_21d);
    assert!(gsi > 0.5, "the fixture's July is green: {gsi}");
    assert!((m.live_herbaceous_pct - moisture::live_herbaceous_pct(gsi)).abs() < 0.5);
    assert!((m.live_woody_pct - moisture::live_woody_pct(gsi)).abs() < 0.5);
    assert_eq!(m.sources.len(), 3);
    assert!(m.sources[0].contains("tmmx") && m.sources[1].contains("fm100") && m.sources[2].contains("vpd"));
    // The kernel now burns at the day's moisture.
    let firecast_sim::KernelConfig::Rothermel { moisture: k, .. } = &s.env.sim.kernel else {
        panic!("kernel changed")
    };
    assert!((k.dead_1h_frac * 100.0 - m.dead_1h_pct).abs() < 1e-9);
    assert!((k.live_herb_frac * 100.0 - m.live_herbaceous_pct).abs() < 1e-9);

    // The growing season index needs the 20 days before the date: early January reaches into
    // 2019, whose files are not there.
    let mut early = s.clone();
    early.weather = Some(WeatherSpec::Gridmet {
        dir: wind_fixtures(),
        date: "2020-01-05".into(),
        fuel_moisture: true,
        sky: Default::default(),
    });
    let err = early.prepare(dir.path()).unwrap_err().to_string();
    assert!(err.contains("tmmn_2019.nc"), "{err}");
    // The Concord kernel has no place for the day's moisture.
    let mut concord = early.clone();
    concord.env.sim.kernel = firecast_sim::KernelConfig::default();
    concord.weather = s.weather.clone();
    let err = concord.prepare(dir.path()).unwrap_err().to_string();
    assert!(err.contains("Rothermel kernel"), "{err}");
}

#[test]
fn weather_errors_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let err = with_weather("2021-06-01").prepare(dir.path()).unwrap_err();
    assert!(matches!(err, EpisodeError::Gridmet(_)), "{err}");
    assert!(err.to_string().contains("vs_2021.nc"), "{err}");
    let err = with_weather("2020-12-31")
        .prepare(dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("th_2020.nc") && err.contains("missing on 2020-12-31"),
        "{err}"
    );
    let err = with_weather("2020-02-30")
        .prepare(dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("2020-02-30") && err.contains("does not exist"),
        "{err}"
    );
}

#[test]
fn any_policy_is_recorded_with_its_path_and_the_same_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = scenario();
    s.env.max_steps = 120;
    let land = s.landscape.load(dir.path()).unwrap();
    let mut env = firecast_sim::WildfireEnv::new(&land, &s.env).unwrap();
    let mut agent = firecast_sim::RuleBasedAgent::single_circle();
    let plain = firecast_sim::run_episode(&mut env, &mut agent, 9, |_, _| {});
    let path = dir.path().join("recordings/rule.rrd");
    let outputs = Outputs {
        recording: Some(path.clone()),
        ..Outputs::default()
    };
    let recorded =
        firecast_episodes::record_episode(&mut env, &mut agent, &land, "circle agent", 9, &outputs).unwrap();
    assert_eq!(recorded, plain, "recording does not change the episode");
    assert!(std::fs::metadata(&path).unwrap().len() > 0);
    // The same episode recorded again is the same file, byte for byte (a stage's outputs
    // hash the same on every run).
    let again = dir.path().join("recordings/rule-again.rrd");
    let outputs = Outputs {
        recording: Some(again.clone()),
        ..Outputs::default()
    };
    firecast_episodes::record_episode(&mut env, &mut agent, &land, "circle agent", 9, &outputs).unwrap();
    assert!(
        std::fs::read(&path).unwrap() == std::fs::read(&again).unwrap(),
        "two recordings of one episode differ"
    );
    let rerun = std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("../../.venv/bin/rerun");
    if !rerun.exists() {
        return;
    }
    let out = std::process::Command::new(&rerun)
        .args(["rrd", "print"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    for entity in ["env/fire", "env/path", "env/drops_so_far", "stats/cells_burnt"] {
        assert!(text.contains(entity), "recording lacks {entity}");
    }
}

/// The verified engine's ensemble: each run is the MTT engine's arrival map for that run's
/// perturbed wind and moisture, cut at the simulated period.
#[test]
fn an_mtt_ensemble_is_the_engines_arrival_map_per_run() {
    use firecast_episodes::ensemble::{Perturbation, Setup};
    use firecast_spread::mtt::{self, MttConfig};
    let dir = tempfile::tempdir().unwrap();
    let mut s = scenario();
    s.env.sim.kernel = firecast_sim::KernelConfig::rothermel_default();
    s.env.max_steps = 30; // 6 hours
    let setup = Setup::new(s, dir.path(), None)
        .unwrap()
        .with_perturbation(Perturbation::NONE);
    let e = firecast_episodes::free_spread::run_mtt(&setup, 2, 5, |_| {}).unwrap();
    assert_eq!(e.episodes.len(), 2);
    assert_eq!(e.strategy, "none");
    let (env, _) = setup.run_env(5);
    let cfg = MttConfig {
        moisture: match env.sim.kernel {
            firecast_sim::KernelConfig::Rothermel { moisture, .. } => moisture,
            _ => unreachable!(),
        },
        wind: env.sim.wind,
        stencil_radius: mtt::DEFAULT_STENCIL_RADIUS,
        max_time_h: f64::from(env.max_steps) * env.sim.dt_min / 60.0,
    };
    let [x, y] = setup.ignition;
    let direct = mtt::arrival_times_h(&setup.landscape, &cfg, &[(x, y)]).unwrap();
    let burned = direct.iter().filter(|&&t| t <= cfg.max_time_h).count() as u32;
    let run = &e.episodes[0];
    assert!(burned > 50, "{burned} cells in 6 h");
    assert_eq!(run.cells_burned, burned);
    assert_eq!(run.burned_per_step.len(), 31);
    assert_eq!(*run.burned_per_step.last().unwrap(), burned);
    assert!(run.burned_per_step.windows(2).all(|w| w[0] <= w[1]));
    assert_eq!((run.helitacks, run.drops.len()), (0, 0));
    // Without perturbation both runs are the same fire; the ensemble's earliest arrival is it.
    assert_eq!(e.episodes[1].cells_burned, burned);
    for (i, t) in direct.iter().enumerate() {
        let expect = (*t <= cfg.max_time_h).then_some(*t as f32);
        assert_eq!(e.arrival_first_h[i], expect, "cell {i}");
    }
    // Suppression needs the automaton.
    let mut concord = scenario();
    concord.env.max_steps = 30;
    let setup = Setup::new(concord, dir.path(), None).unwrap();
    let err = firecast_episodes::free_spread::run_mtt(&setup, 1, 0, |_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("Rothermel kernel"), "{err}");
}
