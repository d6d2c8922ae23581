//! The MTT engine against Rothermel's ellipse on a small subset of the verification cases
//! (the full table: `firecast sim verify`, docs/results/spread-verification.md).

use firecast_spread::verify::{Engine, VerifyOptions, markdown_table, quick_cases, run};

#[test]
fn mtt_matches_the_ellipse_on_the_quick_cases() {
    let rows = run(&quick_cases(), &[Engine::Mtt], &VerifyOptions::default());
    let table = markdown_table(&rows);
    println!("{table}");
    assert!(!rows.is_empty());
    assert!(rows.iter().filter(|r| r.resolved).count() >= 6);
    for r in rows.iter().filter(|r| r.resolved) {
        assert!(
            r.pass,
            "{} at {} m, {} h fails:\n{table}",
            r.case, r.cell_m, r.time_h
        );
    }
}

#[test]
fn no_spread_cases_burn_nothing_beyond_the_ignition_in_either_engine() {
    let cases = firecast_spread::verify::no_spread_cases();
    let rows = run(
        &cases,
        &[Engine::Automaton, Engine::Mtt],
        &VerifyOptions::default(),
    );
    for r in &rows {
        assert!(r.pass, "{} ({}) spread", r.case, r.engine.name());
    }
}

#[test]
#[ignore = "the full table: run with --ignored --nocapture"]
fn full_table() {
    let cases = firecast_spread::verify::all_cases();
    let r = std::env::var("STENCIL")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(firecast_spread::mtt::DEFAULT_STENCIL_RADIUS);
    let rows = run(
        &cases,
        &[Engine::Automaton, Engine::Mtt],
        &VerifyOptions { stencil_radius: r },
    );
    println!("{}", firecast_spread::verify::exact_table(&cases));
    println!("{}", markdown_table(&rows));
}
