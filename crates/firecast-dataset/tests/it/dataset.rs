use firecast_dataset::Tier;
use firecast_dataset::dataset::{
    DatasetConfig, Framing, FramingKind, SplitConfig, SplitMethod, TEST, TRAIN, VAL, build, overlap_groups,
};
use firecast_dataset::windows::{WindowSample, WindowTable};
use proptest::prelude::*;

/// A window table of `n` samples over days −60…+14 with values that encode (sample, day).
fn table(events: &[(u32, u32, i32, Tier)]) -> WindowTable {
    let n_days = 75;
    let samples: Vec<WindowSample> = events
        .iter()
        .enumerate()
        .map(|(k, &(j, i, day, tier))| WindowSample {
            sample_id: k as u32,
            lat: 40.0,
            lon: -105.0,
            time_ms: firecast_dataset::time::day_start_ms(day),
            event_day: day,
            tier,
            source_row: None,
            cell: (j, i),
            cell_lat: 40.0,
            cell_lon: -105.0,
            true_probability: None,
        })
        .collect();
    let mut values = Vec::new();
    for s in 0..samples.len() {
        for d in 0..n_days {
            values.push(s as f32 * 1000.0 + d as f32);
            values.push(-(d as f32));
        }
    }
    WindowTable {
        features: vec!["pr".into(), "tmmx".into()],
        first_offset: -60,
        n_days,
        samples,
        values,
        row_labels: None,
    }
}

const D2020: i32 = 43_829; // 2020-01-01

fn cfg(kind: FramingKind) -> DatasetConfig {
    DatasetConfig {
        name: "test".into(),
        framing: Framing {
            kind,
            lead_days: 1,
            window_days: 30,
        },
        split: SplitConfig::default(),
        description: String::new(),
    }
}

#[test]
fn paper_framing_is_the_published_layout() {
    let t = table(&[
        (0, 0, D2020 + 100, Tier::Positive),
        (1, 1, D2020 + 100, Tier::Far),
    ]);
    let ds = build(&t, &cfg(FramingKind::Paper)).unwrap();
    assert_eq!(ds.table.n_days, 75);
    assert_eq!(ds.label_offsets, (-60, 14));
    let labels = |s: usize| -> Vec<bool> {
        (0..75)
            .map(|d| firecast_dataset::table::row_label(&ds.table, s, d))
            .collect()
    };
    let mut positive = vec![false; 60];
    positive.extend(vec![true; 15]);
    assert_eq!(labels(0), positive);
    assert_eq!(labels(1), vec![false; 75]);
    assert_eq!(ds.table.row(0, 0), &[0.0, 0.0]);
}

#[test]
fn forecast_framing_ends_lead_days_before_the_predicted_date() {
    let t = table(&[
        (0, 0, D2020 + 100, Tier::Positive),
        (1, 1, D2020 + 100, Tier::Near),
    ]);
    let ds = build(&t, &cfg(FramingKind::Forecast)).unwrap();
    assert_eq!(ds.label_offsets, (-30, -1));
    assert_eq!(ds.table.n_days, 30);
    // Slot 0 is day −30 = source slot 30; the last is day −1 = source slot 59.
    assert_eq!(ds.table.row(0, 0), &[30.0, -30.0]);
    assert_eq!(ds.table.row(1, 29), &[1059.0, -59.0]);
    assert!(ds.table.samples[0].label());
    assert!(!ds.table.samples[1].label());
    // No input row is labelled with a fire: all of them precede the predicted date.
    assert!((0..30).all(|d| !firecast_dataset::table::row_label(&ds.table, 0, d)));
}

#[test]
fn a_framing_wider_than_the_extraction_and_a_zero_lead_are_config_errors() {
    let t = table(&[(0, 0, D2020, Tier::Positive)]);
    let mut c = cfg(FramingKind::Forecast);
    c.framing.window_days = 90;
    let err = build(&t, &c).unwrap_err().to_string();
    assert!(err.starts_with("`framing`: needs day offsets -90…-1"), "{err}");
    c.framing.lead_days = 0;
    let err = build(&t, &c).unwrap_err().to_string();
    assert!(err.starts_with("`framing.lead_days`"), "{err}");
}

#[test]
fn temporal_split_puts_the_last_months_in_test() {
    let events: Vec<_> = (0..24)
        .map(|k| {
            (
                k,
                0,
                D2020 + 15 * k as i32,
                if k % 3 == 0 { Tier::Positive } else { Tier::Far },
            )
        })
        .collect();
    let ds = build(&table(&events), &cfg(FramingKind::Paper)).unwrap();
    // The last event is 2020-12-16, so the last 4 months start on 2020-09-01.
    assert_eq!(
        ds.test_from.map(firecast_dataset::time::format_date).as_deref(),
        Some("2020-09-01")
    );
    for (s, split) in ds.table.samples.iter().zip(&ds.splits) {
        assert_eq!(
            *split == TEST,
            s.event_day >= ds.test_from.unwrap(),
            "{}",
            s.event_day
        );
    }
    assert!(ds.splits.contains(&VAL) && ds.splits.contains(&TRAIN));
}

#[test]
fn the_same_config_gives_the_same_version_and_a_changed_one_does_not() {
    let events: Vec<_> = (0..40)
        .map(|k| {
            (
                k % 7,
                0,
                D2020 + 9 * k as i32,
                if k % 4 == 0 { Tier::Positive } else { Tier::Yearly },
            )
        })
        .collect();
    let t = table(&events);
    let mut c = cfg(FramingKind::Forecast);
    c.split.method = SplitMethod::StratifiedRandom;
    let a = build(&t, &c).unwrap();
    let b = build(&t, &c).unwrap();
    assert_eq!(a.version, b.version);
    assert_eq!(a.splits, b.splits);
    c.split.seed = 43;
    assert_ne!(build(&t, &c).unwrap().version, a.version);
}

proptest! {
    /// Whatever the samples, no (cell, date) is in two splits: samples in different splits
    /// never share a cell with overlapping day ranges.
    #[test]
    fn no_place_date_is_in_two_splits(
        events in prop::collection::vec((0u32..3, 0u32..2, 0i32..400, any::<bool>()), 1..60),
        seed in 0u64..1000,
        random in any::<bool>(),
    ) {
        let events: Vec<_> = events
            .into_iter()
            .map(|(j, i, d, p)| (j, i, D2020 + d, if p { Tier::Positive } else { Tier::Far }))
            .collect();
        let t = table(&events);
        let mut c = cfg(FramingKind::Paper);
        c.split.seed = seed;
        if random {
            c.split.method = SplitMethod::StratifiedRandom;
        }
        let ds = build(&t, &c).unwrap();
        let groups = overlap_groups(&ds.table);
        let s = &ds.table.samples;
        for a in 0..s.len() {
            for b in a + 1..s.len() {
                let overlap = s[a].cell == s[b].cell && (s[a].event_day - s[b].event_day).abs() <= 74;
                if overlap {
                    prop_assert_eq!(groups[a], groups[b]);
                    prop_assert_eq!(ds.splits[a], ds.splits[b]);
                }
            }
        }
    }
}

/// Writes a small dataset into `dir` (its Parquet tables, card, map and `dataset.json`).
pub(crate) fn write_small_dataset(dir: &std::path::Path) {
    let events: Vec<_> = (0..30)
        .map(|k| {
            (
                k % 5,
                k % 3,
                D2020 + 11 * k as i32,
                if k % 3 == 0 { Tier::Positive } else { Tier::Yearly },
            )
        })
        .collect();
    let c = cfg(FramingKind::Paper);
    let ds = build(&table(&events), &c).unwrap();
    let grid = firecast_dataset::card::MapGrid {
        lat_north: 41.0,
        lon_west: -106.0,
        step_deg: 0.5,
        n_lat: 4,
        n_lon: 4,
        land_runs: Vec::new(),
    };
    firecast_dataset::folder::write(dir, &ds, &c, &grid, &Default::default(), None).unwrap();
}

/// Flips a few bytes in the middle of `path` (inside the data, not the footer).
fn damage(path: &std::path::Path) {
    let mut bytes = std::fs::read(path).unwrap();
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 4] {
        *b ^= 0x5A;
    }
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn a_damaged_file_is_refused_by_its_own_name() {
    use firecast_dataset::dataset::read_window_table;
    use firecast_dataset::table::{DAYS_FILE, SAMPLES_FILE};
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write_small_dataset(&dir);
    let intact = read_window_table(&dir).unwrap();
    assert_eq!(intact.table.samples.len(), 30);

    // Bytes flipped inside samples.parquet: the error names samples.parquet, not days.parquet.
    let pristine = std::fs::read(dir.join(SAMPLES_FILE)).unwrap();
    damage(&dir.join(SAMPLES_FILE));
    let e = read_window_table(&dir)
        .err()
        .expect("a damaged samples.parquet must be refused");
    let msg = e.to_string();
    assert!(
        msg.contains(SAMPLES_FILE) && !msg.contains(DAYS_FILE) && msg.contains("damaged"),
        "{msg}"
    );
    assert!(
        matches!(e, firecast_dataset::DatasetError::Damaged { .. }),
        "{e:?}"
    );
    std::fs::write(dir.join(SAMPLES_FILE), pristine).unwrap();
    assert!(read_window_table(&dir).is_ok());

    // The same for days.parquet and for a file the reader never parses (the card).
    for name in [DAYS_FILE, firecast_dataset::dataset::CARD_FILE] {
        let pristine = std::fs::read(dir.join(name)).unwrap();
        damage(&dir.join(name));
        let msg = read_window_table(&dir).err().expect("refused").to_string();
        assert!(
            msg.contains(name) && msg.contains("dataset.json"),
            "{name}: {msg}"
        );
        std::fs::write(dir.join(name), pristine).unwrap();
    }

    // A listed file that is gone.
    std::fs::remove_file(dir.join(firecast_dataset::dataset::STATS_FILE)).unwrap();
    let msg = read_window_table(&dir).err().expect("refused").to_string();
    assert!(
        msg.contains(firecast_dataset::dataset::STATS_FILE) && msg.contains("missing"),
        "{msg}"
    );
}
