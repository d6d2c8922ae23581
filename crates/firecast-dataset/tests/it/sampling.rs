use firecast_dataset::Tier;
use firecast_dataset::geo::haversine_km;
use firecast_dataset::land::LandMask;
use firecast_dataset::sampling::{
    IgnitionRules, IncidentPoint, NegativeConfig, Sample, TierCounts, Variant, dedup_ignitions,
    sample_negatives,
};

use crate::utc;

const H: i64 = 3_600_000;

fn report(row: u64, hours: f64, lat: f64, lon: f64) -> IncidentPoint {
    IncidentPoint {
        row,
        time_ms: (hours * H as f64) as i64 + utc(2020, 7, 1, 0),
        lat,
        lon,
    }
}

#[test]
fn dedup_follows_the_authors_sequential_rule_exactly() {
    let reports = vec![
        report(1, 0.0, 40.0, -105.0),
        report(2, 1.0, 41.0, -105.0),  // 111 km away but 1 h later: dropped (time)
        report(3, 3.0, 40.01, -105.0), // 3 h later but 1.1 km away: dropped (distance)
        report(4, 4.0, 40.2, -105.0),  // 22 km, 4 h: kept
        report(5, 4.5, 45.0, -100.0),  // 0.5 h after row 4: dropped, however far
        report(6, 7.0, 60.0, -105.0),  // outside the CONUS box
        report(7, 8.0, 40.0, -105.0),  // row 1's place again; against row 4 it is far enough: kept
        report(8, 8.0, 35.0, -90.0),   // same instant as row 7, later row: dropped (time)
    ];
    // Shuffled input: the rule sorts by (time, row) itself.
    let mut shuffled = reports.clone();
    shuffled.reverse();
    let out = dedup_ignitions(&shuffled, &IgnitionRules::default(), None);
    let kept: Vec<u64> = out.positives.iter().map(|p| p.source_row.unwrap()).collect();
    assert_eq!(kept, vec![1, 4, 7]);
    let c = &out.counts;
    assert_eq!((c.reports, c.kept), (8, 3));
    assert_eq!(c.outside_region, 1);
    assert_eq!(c.within_gap_hours, 3);
    assert_eq!(c.within_distance_km, 1);
    assert_eq!(c.off_land, 0);
    let mut dropped = out.dropped.clone();
    dropped.sort();
    assert_eq!(
        dropped,
        vec![
            (2, "within_gap_hours"),
            (3, "within_distance_km"),
            (5, "within_gap_hours"),
            (6, "outside_region"),
            (8, "within_gap_hours")
        ]
    );
}

#[test]
fn dedup_drops_reports_off_the_gridmet_land_mask() {
    // A 2 x 2 grid of 1/24 degree cells; the south-east cell has no data.
    let lats = vec![40.0, 40.0 - 1.0 / 24.0];
    let lons = vec![-105.0, -105.0 + 1.0 / 24.0];
    let mask = LandMask::from_grid(lats, lons, vec![true, true, true, false]);
    let reports = vec![
        report(1, 0.0, 40.0, -105.0),
        report(2, 10.0, 40.0 - 1.0 / 24.0, -105.0 + 1.0 / 24.0), // masked cell
        report(3, 20.0, 45.0, -100.0),                           // outside the mask's grid
    ];
    let out = dedup_ignitions(&reports, &IgnitionRules::default(), Some(&mask));
    assert_eq!(out.counts.kept, 1);
    assert_eq!(out.counts.off_land, 2);
    let no_mask = IgnitionRules {
        land_mask: false,
        ..Default::default()
    };
    assert_eq!(dedup_ignitions(&reports, &no_mask, Some(&mask)).counts.kept, 3);
}

fn positive(lat: f64, lon: f64, time_ms: i64, row: u64) -> Sample {
    Sample {
        lat,
        lon,
        time_ms,
        tier: Tier::Positive,
        source_row: Some(row),
    }
}

fn code_variant() -> NegativeConfig {
    NegativeConfig {
        variant: Variant::Code,
        far_count: Some(0),
        ..Default::default()
    }
}

#[test]
fn code_variant_yearly_negatives_match_a_hand_count() {
    let a = utc(2016, 6, 1, 12); // 823 days after 2014-03-01: two whole years back
    let b = utc(2016, 6, 10, 12); // same place, 9 days later: both its years clash with A's
    let c = utc(2014, 6, 1, 0); // under a year after the period start: none
    let d = utc(2015, 1, 10, 0); // 315 days: none
    let e = d + 365 * 86_400_000; // E's one year back is exactly D: skipped
    let positives = vec![
        positive(40.0, -105.0, c, 1),
        positive(35.0, -110.0, d, 2),
        positive(35.0, -110.0, e, 3),
        positive(38.0, -100.0, a, 4),
        positive(38.0, -100.0, b, 5),
    ];
    let out = sample_negatives(&positives, &code_variant(), None).unwrap();
    let y = &out.yearly;
    assert_eq!(y.candidates, 5);
    assert_eq!(y.accepted, 2);
    assert_eq!(y.rejected.get("duplicate_within_tier"), Some(&2));
    assert_eq!(y.rejected.get("exact_positive"), Some(&1));
    let yearly: Vec<&Sample> = out.samples.iter().filter(|s| s.tier == Tier::Yearly).collect();
    let mut times: Vec<i64> = yearly.iter().map(|s| s.time_ms).collect();
    times.sort();
    assert_eq!(times, vec![a - 730 * 86_400_000, a - 365 * 86_400_000]);
    assert!(yearly.iter().all(|s| (s.lat, s.lon) == (38.0, -100.0)));
    // Positives are all in the output, once.
    assert_eq!(out.samples.iter().filter(|s| s.tier == Tier::Positive).count(), 5);
}

/// Isolated positives: 3 degrees apart and months apart.
fn isolated_positives(n: usize) -> Vec<Sample> {
    (0..n)
        .map(|k| {
            let lat = 30.0 + 3.0 * (k % 6) as f64;
            let lon = -120.0 + 3.0 * (k / 6) as f64;
            positive(
                lat,
                lon,
                utc(2016, 1, 1, 0) + k as i64 * 100 * 86_400_000 / 10,
                k as u64,
            )
        })
        .collect()
}

#[test]
fn code_variant_near_negatives_reject_almost_everything_unless_the_origin_is_excluded() {
    let positives = isolated_positives(36);
    let mut cfg = code_variant();
    cfg.period_start = "2000-01-01".into();
    cfg.period_end = "2030-01-01".into();
    let out = sample_negatives(&positives, &cfg, None).unwrap();
    // One attempt per positive, each accepted: nothing else is within 100 km or 5 km.
    assert_eq!(out.near.candidates, 36);
    assert_eq!(out.near.accepted, 36, "{:?}", out.near.rejected);
    for s in out.samples.iter().filter(|s| s.tier == Tier::Near) {
        let origin = &positives[s.source_row.unwrap() as usize];
        let d = haversine_km(origin.lat, origin.lon, s.lat, s.lon);
        assert!((0.09..=100.5).contains(&d), "placed {d} km away");
        let days = (s.time_ms - origin.time_ms).abs() / 86_400_000;
        assert!((90..=120).contains(&days), "shifted {days} days");
    }
    // As written by the authors, the origin itself is in the check and rejects the candidate
    // unless the geodesic offset happens to exceed 100 km by haversine.
    cfg.exclude_origin = false;
    let quirk = sample_negatives(&positives, &cfg, None).unwrap();
    assert!(quirk.near.accepted <= 3, "{} accepted", quirk.near.accepted);
    assert_eq!(
        quirk.near.rejected.get("fire_nearby").copied().unwrap_or(0) + quirk.near.accepted,
        36
    );
}

#[test]
fn paper_variant_scales_the_tiers_and_respects_every_distance_rule() {
    let positives = isolated_positives(40);
    let cfg = NegativeConfig {
        period_start: "2015-01-01".into(),
        period_end: "2020-12-31".into(),
        ..Default::default()
    };
    assert_eq!(cfg.counts, TierCounts::Proportional);
    let out = sample_negatives(&positives, &cfg, None).unwrap();
    // 40 / 50,720 of 5,000 / 35,000 / 36,000.
    assert_eq!(out.far.requested, Some(4));
    assert_eq!(out.near.requested, Some(28));
    assert_eq!(out.yearly.requested, Some(28));
    assert_eq!(out.far.accepted, 4);
    assert_eq!(out.near.accepted, 28);
    assert!(out.yearly.accepted <= 28 && out.yearly.accepted > 0);
    for s in &out.samples {
        match s.tier {
            Tier::Far => assert!(
                positives
                    .iter()
                    .all(|p| haversine_km(p.lat, p.lon, s.lat, s.lon) >= 100.0)
            ),
            Tier::Near => {
                let close = positives.iter().any(|p| {
                    haversine_km(p.lat, p.lon, s.lat, s.lon) < 100.0
                        && (p.time_ms - s.time_ms).abs() / 86_400_000 < 90
                });
                assert!(!close, "a near negative has a fire within 100 km and 90 days");
            }
            _ => {}
        }
    }
    // Within a tier: nothing closer than 5 km and 120 days.
    for tier in [Tier::Far, Tier::Near, Tier::Yearly] {
        let t: Vec<&Sample> = out.samples.iter().filter(|s| s.tier == tier).collect();
        for (i, a) in t.iter().enumerate() {
            for b in &t[i + 1..] {
                let clash = haversine_km(a.lat, a.lon, b.lat, b.lon) < 5.0
                    && (a.time_ms - b.time_ms).abs() / 86_400_000 < 120;
                assert!(!clash, "{tier:?} duplicates");
            }
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_samples_and_another_seed_does_not() {
    let positives = isolated_positives(30);
    let cfg = NegativeConfig {
        period_start: "2015-01-01".into(),
        period_end: "2020-12-31".into(),
        ..Default::default()
    };
    let a = sample_negatives(&positives, &cfg, None).unwrap().samples;
    let b = sample_negatives(&positives, &cfg, None).unwrap().samples;
    assert_eq!(a, b);
    let other = NegativeConfig { seed: 7, ..cfg };
    assert_ne!(a, sample_negatives(&positives, &other, None).unwrap().samples);
}

/// 60 positives 3° apart, one every 30 days from 2015-06-01 (to 2020-04).
fn spread_positives() -> Vec<Sample> {
    (0..60)
        .map(|k| {
            let lat = 30.0 + 3.0 * (k % 6) as f64;
            let lon = -120.0 + 3.0 * (k / 6) as f64;
            positive(
                lat,
                lon,
                utc(2015, 6, 1, 12) + k as i64 * 30 * 86_400_000,
                k as u64,
            )
        })
        .collect()
}

#[test]
fn strata_give_every_period_and_block_its_own_negatives_at_the_designed_ratio() {
    let positives = spread_positives();
    let cut = utc(2019, 9, 1, 7);
    let base = NegativeConfig {
        period_start: "2015-01-01".into(),
        period_end: "2020-06-30".into(),
        ..Default::default()
    };
    let late = |samples: &[Sample], tier: Option<Tier>| {
        samples
            .iter()
            .filter(|s| s.time_ms >= cut && tier.is_none_or(|t| s.tier == t))
            .count()
    };
    // The authors' sampling: near and yearly negatives go back in time, so the last months
    // hold fewer negatives per positive than the design's 76,080 : 50,720.
    let plain = sample_negatives(&positives, &base, None).unwrap().samples;
    let late_pos = late(&plain, Some(Tier::Positive));
    assert_eq!(late_pos, 8);
    let plain_ratio = (late(&plain, None) - late_pos) as f64 / late_pos as f64;

    let cfg = NegativeConfig {
        strata: Some(firecast_dataset::sampling::Strata {
            cuts: vec!["2019-09-01".into()],
            block_degrees: None,
        }),
        ..base.clone()
    };
    let out = sample_negatives(&positives, &cfg, None).unwrap();
    assert_eq!(out.strata.len(), 2, "{:?}", out.strata);
    // Each period gets 5,000 + 35,000 + 36,000 per 50,720 positives of negatives (rounded per
    // tier), whatever its tiers could give: the late period has no earlier year inside it.
    for s in &out.strata {
        let design = [5_000.0, 35_000.0, 36_000.0]
            .iter()
            .map(|t: &f64| ((t * 60.0 / 50_720.0).round() * s.positives as f64 / 60.0).round())
            .sum::<f64>() as u64;
        assert_eq!(s.requested, design, "{s:?}");
        assert_eq!(s.far + s.near + s.yearly, s.requested, "{s:?}");
    }
    let last = &out.strata[1];
    assert_eq!(
        (last.first_day.as_str(), last.last_day.as_str()),
        ("2019-09-01", "2020-06-30")
    );
    assert_eq!(last.positives, 8);
    assert_eq!(last.yearly, 0);
    assert!(last.moved_to_near + last.moved_to_far > 0, "{last:?}");
    let strat_ratio = (late(&out.samples, None) - 8) as f64 / 8.0;
    assert!(
        (strat_ratio - 76_080.0 / 50_720.0).abs() < 0.4 && strat_ratio > plain_ratio,
        "late period: {strat_ratio:.2} negatives per positive stratified, {plain_ratio:.2} plain"
    );
    // Every near and yearly negative lies in its positive's period.
    for s in out
        .samples
        .iter()
        .filter(|s| matches!(s.tier, Tier::Near | Tier::Yearly))
    {
        let origin = &positives[s.source_row.unwrap() as usize];
        assert_eq!(s.time_ms >= cut, origin.time_ms >= cut, "{s:?} from {origin:?}");
    }
    // The same seed, the same samples.
    assert_eq!(
        out.samples,
        sample_negatives(&positives, &cfg, None).unwrap().samples
    );

    // Blocks: every negative falls in the block of the positives it was drawn for.
    let blocks = NegativeConfig {
        strata: Some(firecast_dataset::sampling::Strata {
            cuts: vec![],
            block_degrees: Some(6.0),
        }),
        ..base.clone()
    };
    let out = sample_negatives(&positives, &blocks, None).unwrap();
    let block = |lat: f64, lon: f64| ((lat / 6.0).floor() as i64, (lon / 6.0).floor() as i64);
    for s in out
        .samples
        .iter()
        .filter(|s| matches!(s.tier, Tier::Near | Tier::Yearly))
    {
        let origin = &positives[s.source_row.unwrap() as usize];
        assert_eq!(block(s.lat, s.lon), block(origin.lat, origin.lon));
    }
    let with_positives: std::collections::BTreeSet<(i64, i64)> =
        positives.iter().map(|p| block(p.lat, p.lon)).collect();
    for s in out.samples.iter().filter(|s| s.tier == Tier::Far) {
        assert!(with_positives.contains(&block(s.lat, s.lon)), "{s:?}");
    }
    assert_eq!(out.strata.len(), with_positives.len());

    // Bad strata name their key; the authors' code variant has no counts to share out.
    let bad = |strata: firecast_dataset::sampling::Strata, variant: Variant| {
        let cfg = NegativeConfig {
            strata: Some(strata),
            variant,
            ..base.clone()
        };
        sample_negatives(&positives, &cfg, None).unwrap_err().to_string()
    };
    let cuts = |c: &[&str]| firecast_dataset::sampling::Strata {
        cuts: c.iter().map(|s| s.to_string()).collect(),
        block_degrees: None,
    };
    assert!(bad(cuts(&["2019-13-01"]), Variant::Paper).contains("strata.cuts[0]"));
    assert!(bad(cuts(&["2019-09-01", "2018-01-01"]), Variant::Paper).contains("strata.cuts[1]"));
    assert!(bad(cuts(&["2030-01-01"]), Variant::Paper).contains("strata.cuts[0]"));
    assert!(bad(cuts(&["2019-09-01"]), Variant::Code).contains("strata"));
}
