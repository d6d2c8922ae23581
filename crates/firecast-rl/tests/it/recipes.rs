//! The recipes in `experiments/rl/`: every training spec resolves through its `extends`
//! chain, its fire file loads, and an ablation differs from the recipe it extends only in
//! what it says it changes.

use std::path::{Path, PathBuf};

use firecast_rl::spec::{EnvSpec, FiresSpec, TrainSpec, fires_path};
use firecast_sim::RewardWeights;

fn repo() -> PathBuf {
    PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()))
        .join("../..")
}

/// Every YAML file under `experiments/rl/` that is a training spec (fire files hold `train:`).
fn recipes() -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut folders = vec![PathBuf::from("experiments/rl")];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(repo().join(&folder)).expect("experiments/rl") {
            let name = entry.expect("an entry").file_name();
            let path = folder.join(&name);
            if repo().join(&path).is_dir() {
                folders.push(path);
            } else if path.extension().is_some_and(|e| e == "yaml") {
                let text = std::fs::read_to_string(repo().join(&path)).expect("a recipe");
                if !text.lines().any(|l| l.starts_with("train:")) {
                    out.push(path);
                }
            }
        }
    }
    out.sort();
    out
}

fn resolved(file: &str) -> serde_json::Value {
    let spec = TrainSpec::load(&repo(), Path::new(file), &[]).expect(file);
    serde_json::to_value(spec).expect("a spec serializes")
}

#[test]
fn every_recipe_resolves_and_its_fires_load() {
    let recipes = recipes();
    assert!(recipes.len() >= 14, "{recipes:?}");
    for file in &recipes {
        let spec = TrainSpec::load(&repo(), file, &[]).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        assert_eq!(
            Some(spec.name.as_str()),
            file.file_stem().and_then(|s| s.to_str()),
            "a recipe is named after its file"
        );
        if let Some(fires) = fires_path(&spec) {
            let reward = match &spec.env {
                EnvSpec::Helitack { reward, .. } => reward.clone(),
                EnvSpec::Cartpole => None,
            };
            FiresSpec::load(&repo().join(fires))
                .and_then(|f| f.with_reward(reward.as_ref()))
                .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        }
    }
}

#[test]
fn an_ablation_changes_only_what_it_names() {
    let best = resolved("experiments/rl/best-agent-small-map.yaml");
    let mut expected = best.clone();
    expected["name"] = "imitation-only-32-rounds".into();
    expected["imitation"]["kickstart"] = 0.0.into();
    expected["ppo"]["total_timesteps"] = 0.into();
    assert_eq!(
        resolved("experiments/rl/ablations/imitation-only-32-rounds.yaml"),
        expected
    );

    // The paper map's recipe is the small map's with a window and other fires.
    let paper = resolved("experiments/rl/best-agent-paper-map.yaml");
    let mut expected = best;
    expected["name"] = "best-agent-paper-map".into();
    expected["env"]["fires"] = "experiments/rl/fires/paper-map.yaml".into();
    expected["policy"]["window"] = serde_json::json!([64, 96]);
    expected["policy"]["context"] = 4.into();
    assert_eq!(paper, expected);
}

#[test]
fn a_recipe_reward_replaces_the_fire_file_reward() {
    let spec = TrainSpec::load(
        &repo(),
        Path::new("experiments/rl/ablations/suppression-reward.yaml"),
        &[],
    )
    .expect("the recipe");
    let EnvSpec::Helitack { reward, fires } = &spec.env else {
        panic!("a helitack recipe")
    };
    let fires = FiresSpec::load(&repo().join(fires.as_ref().expect("a fire file"))).expect("the fires");
    assert_eq!(
        fires.train.env.reward,
        RewardWeights::p2(),
        "the fire file's own reward"
    );
    let fires = fires.with_reward(reward.as_ref()).expect("the recipe's reward");
    assert_eq!(fires.train.env.reward, RewardWeights::suppression());
    assert_eq!(fires.evaluate.env.reward, RewardWeights::suppression());

    // The best recipe's containment reward: suppression without the quenched term, −1 a cell.
    let best = TrainSpec::load(
        &repo(),
        Path::new("experiments/rl/best-agent-small-map.yaml"),
        &[],
    )
    .expect("the recipe");
    let EnvSpec::Helitack { reward, fires } = &best.env else {
        panic!("a helitack recipe")
    };
    let fires = FiresSpec::load(&repo().join(fires.as_ref().expect("a fire file")))
        .and_then(|f| f.with_reward(reward.as_ref()))
        .expect("the fires");
    let containment = RewardWeights {
        quenched: 0.0,
        new_burnt: -1.0,
        ..RewardWeights::suppression()
    };
    assert_eq!(fires.train.env.reward, containment);
}

#[test]
fn a_bad_key_in_an_extended_recipe_names_its_file_and_line() {
    let dir = tempfile::tempdir().expect("a folder");
    std::fs::write(
        dir.path().join("base.yaml"),
        "name: base\nenv:\n  kind: cartpole\nppo:\n  preset: cartpole_zoo\n",
    )
    .expect("write");
    std::fs::write(
        dir.path().join("child.yaml"),
        "extends: base.yaml\nname: child\nppo:\n  batch_sise: 64\n",
    )
    .expect("write");
    let error = TrainSpec::load(dir.path(), Path::new("child.yaml"), &[]).expect_err("a typo");
    let text = error.to_string();
    assert!(text.starts_with("child.yaml:4:"), "{text}");
    assert!(text.contains("batch_sise"), "{text}");
    // A reward weight that does not exist is refused too.
    std::fs::write(
        dir.path().join("child.yaml"),
        "extends: base.yaml\nname: child\nenv:\n  kind: helitack\n  reward: {profile: suppression, quenchd: 1}\n",
    )
    .expect("write");
    let error = TrainSpec::load(dir.path(), Path::new("child.yaml"), &[]).expect_err("a bad weight");
    assert!(error.to_string().contains("quenchd"), "{error}");
}
