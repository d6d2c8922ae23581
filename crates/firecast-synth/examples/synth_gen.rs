//! Generates synthetic sources and prints timing and summary statistics.
//!
//! ```text
//! cargo run --release -p firecast-synth --example synth_gen -- OUT_DIR [--years 2021 2021]
//!     [--vars tmmx,pr|all|none] [--box LAT_MIN LAT_MAX LON_MIN LON_MAX] [--seed N]
//!     [--order latlon|lonlat|vintage] [--warmup DAYS] [--no-incidents] [--cdf2] [--verify]
//! ```
//!
//! `--verify` opens every written file with `GridmetFile` and reads two days back.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::time::Instant;

use firecast_data::gridmet::{GridmetFile, GridmetVariable};
use firecast_synth::{DimOrderChoice, IgnitionCause, NcVersion, Region, SynthConfig, generate};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = PathBuf::from(args.first().expect("usage: synth_gen OUT_DIR [options]"));
    let mut config = SynthConfig::new(42, Region::Conus, (2021, 2021));
    let mut verify = false;
    let mut k = 1;
    while k < args.len() {
        let a = args[k].as_str();
        let next = |n: usize| args[k + n].clone();
        match a {
            "--years" => {
                config.years = (next(1).parse().unwrap(), next(2).parse().unwrap());
                k += 2;
            }
            "--seed" => {
                config.seed = next(1).parse().unwrap();
                k += 1;
            }
            "--warmup" => {
                config.warmup_days = next(1).parse().unwrap();
                k += 1;
            }
            "--vars" => {
                let v = next(1);
                config.variables = match v.as_str() {
                    "all" => GridmetVariable::ALL.to_vec(),
                    "none" => Vec::new(),
                    list => list
                        .split(',')
                        .map(|s| GridmetVariable::from_short_name(s).expect("variable"))
                        .collect(),
                };
                k += 1;
            }
            "--box" => {
                config.region = Region::Box {
                    lat_min: next(1).parse().unwrap(),
                    lat_max: next(2).parse().unwrap(),
                    lon_min: next(3).parse().unwrap(),
                    lon_max: next(4).parse().unwrap(),
                };
                k += 4;
            }
            "--order" => {
                config.dim_order = match next(1).as_str() {
                    "latlon" => DimOrderChoice::LatLon,
                    "lonlat" => DimOrderChoice::LonLat,
                    _ => DimOrderChoice::ByVintage,
                };
                k += 1;
            }
            "--no-incidents" => config.write_incidents = false,
            "--cdf2" => config.netcdf_version = NcVersion::Cdf2,
            "--verify" => verify = true,
            other => panic!("unknown option {other}"),
        }
        k += 1;
    }
    println!("threads: {}", rayon::current_num_threads());
    let t0 = Instant::now();
    let mut last = 0;
    let summary = generate(&config, &out, &mut |done, total| {
        let pct = done * 10 / total;
        if pct != last {
            last = pct;
            eprint!("{}% ", pct * 10);
        }
    })
    .unwrap();
    eprintln!();
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "window {} x {} ({} land cells), {} days simulated, {} written",
        summary.n_lat, summary.n_lon, summary.land_cells, summary.days_simulated, summary.days_written
    );
    println!("elapsed {secs:.2} s");
    for f in &summary.gridmet_files {
        println!("{}  {} bytes", f.display(), std::fs::metadata(f).unwrap().len());
        if verify {
            let t = Instant::now();
            let (v, _) = GridmetVariable::from_file_name(f).unwrap();
            let file = GridmetFile::open(f, v).unwrap();
            for day in [0, file.days().len() - 1] {
                let grid = file.read_day(day).unwrap();
                let valid: Vec<f32> = grid.iter().copied().filter(|x| x.is_finite()).collect();
                let mean = valid.iter().map(|&x| f64::from(x)).sum::<f64>() / valid.len() as f64;
                println!(
                    "  GridmetFile {:?}: day {} ({:?}) {} valid of {}, mean {mean:.3}",
                    file.dim_order(),
                    day,
                    file.dates()[day],
                    valid.len(),
                    grid.len()
                );
            }
            println!("  read back in {:.2} s", t.elapsed().as_secs_f64());
        }
    }
    if let Some(csv) = &summary.incidents_csv {
        println!(
            "{}  {} bytes",
            csv.display(),
            std::fs::metadata(csv).unwrap().len()
        );
    }
    let count = |c: IgnitionCause| summary.events.iter().filter(|e| e.cause == c).count();
    println!(
        "ignitions {} (human {}, lightning {}, rx {}), records {}",
        summary.ignitions,
        count(IgnitionCause::Human),
        count(IgnitionCause::Lightning),
        count(IgnitionCause::Prescribed),
        summary.reported_records
    );
    let mut by_state: std::collections::BTreeMap<&str, usize> = Default::default();
    let mut by_month = [0usize; 12];
    for e in &summary.events {
        *by_state.entry(e.state).or_default() += 1;
        let (_, m, _) = firecast_data::gridmet::day_to_ymd(e.gridmet_day);
        by_month[m as usize - 1] += 1;
    }
    let mut states: Vec<_> = by_state.into_iter().collect();
    states.sort_by_key(|s| std::cmp::Reverse(s.1));
    println!("top states: {:?}", &states[..states.len().min(15)]);
    println!("by month: {by_month:?}");
}
