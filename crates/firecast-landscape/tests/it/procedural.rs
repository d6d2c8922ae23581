use firecast_landscape::procedural::{ProceduralOptions, generate};
use firecast_landscape::{LandCoverScheme, LandscapeError};

#[test]
fn same_seed_same_landscape_other_seed_differs() {
    let a = generate(&ProceduralOptions::with_seed(7)).unwrap();
    let b = generate(&ProceduralOptions::with_seed(7)).unwrap();
    let c = generate(&ProceduralOptions::with_seed(8)).unwrap();
    assert_eq!(a, b);
    assert_ne!(a.elevation_ft, c.elevation_ft);
    assert_ne!(a.land_cover, c.land_cover);
}

#[test]
fn plausible_classes_and_relief() {
    for seed in 0..8u64 {
        let opts = ProceduralOptions::with_seed(seed);
        let l = generate(&opts).unwrap();
        assert_eq!(
            (l.width, l.height, l.scheme),
            (240, 160, LandCoverScheme::ModisIgbp)
        );
        let n = l.len() as f64;
        let frac = |f: &dyn Fn(u16) -> bool| l.land_cover.iter().filter(|&&c| f(c)).count() as f64 / n;
        assert!(l.land_cover.iter().all(|c| (1..=17).contains(c)));
        let water = frac(&|c| c == 17);
        assert!((0.035..=0.045).contains(&water), "seed {seed}: water {water}");
        let veg = frac(&|c| (1..=10).contains(&c));
        assert!(veg > 0.6, "seed {seed}: vegetation {veg}");
        let forest = frac(&|c| (1..=5).contains(&c));
        let shrub_grass = frac(&|c| matches!(c, 6 | 7 | 9 | 10));
        assert!(
            forest > 0.05 && shrub_grass > 0.2,
            "seed {seed}: forest {forest}, shrub/grass {shrub_grass}"
        );
        let urban = frac(&|c| c == 13);
        assert!(urban > 0.0 && urban < 0.1, "seed {seed}: urban {urban}");
        assert!(frac(&|c| c == 16 || c == 15) > 0.02);

        // Water lies below all other land, and forests sit higher than grassland on average.
        let elev_of = |f: &dyn Fn(u16) -> bool| -> Vec<f32> {
            l.land_cover
                .iter()
                .zip(&l.elevation_ft)
                .filter(|(c, _)| f(**c))
                .map(|(_, e)| *e)
                .collect()
        };
        let max_water = elev_of(&|c| c == 17).into_iter().fold(f32::MIN, f32::max);
        let min_land = elev_of(&|c| c != 17 && c != 11)
            .into_iter()
            .fold(f32::MAX, f32::min);
        assert!(
            max_water <= min_land,
            "seed {seed}: water {max_water} above land {min_land}"
        );
        let mean = |v: Vec<f32>| v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len().max(1) as f64;
        assert!(
            mean(elev_of(&|c| c == 1)) > mean(elev_of(&|c| c == 10)),
            "seed {seed}"
        );

        // Real feet over the requested relief.
        let (lo, hi) = l
            .elevation_ft
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &e| (a.min(e), b.max(e)));
        assert!((f64::from(lo) - opts.min_elevation_ft).abs() < 1.0);
        assert!((f64::from(hi) - (opts.min_elevation_ft + opts.relief_ft)).abs() < 1.0);
        // Neighbouring cells differ by a sane slope (< 100 %).
        for y in 0..l.height {
            for x in 1..l.width {
                let d = (l.elevation_ft[l.index(x, y)] - l.elevation_ft[l.index(x - 1, y)]).abs();
                assert!(
                    f64::from(d) < l.cell_size_ft,
                    "seed {seed}: step {d} ft at ({x},{y})"
                );
            }
        }
    }
}

#[test]
fn georeferenced_at_center_and_snow_with_high_relief() {
    let opts = ProceduralOptions {
        seed: 3,
        width: 120,
        height: 80,
        relief_ft: 12_000.0,
        min_elevation_ft: 1000.0,
        center_lat: 46.85,
        center_lon: -121.76,
        ..ProceduralOptions::default()
    };
    let l = generate(&opts).unwrap();
    assert_eq!(l.georef.crs, "EPSG:4326");
    let (lat, lon) = l.cell_to_lat_lon(60, 40);
    assert!(
        (lat - 46.85).abs() < 0.002 && (lon + 121.76).abs() < 0.003,
        "{lat} {lon}"
    );
    assert!(l.land_cover.contains(&15));
    // Cell size on the ground ≈ 500 ft both ways at the centre.
    let (lat1, lon1) = l.cell_to_lat_lon(61, 41);
    let (m_lat, m_lon) = firecast_landscape::georef::metres_per_degree(46.85);
    assert!(((lat1 - lat) * m_lat - 152.4).abs() < 1e-6);
    assert!(((lon1 - lon) * m_lon - 152.4).abs() < 1e-6);
}

#[test]
fn bad_options_are_errors() {
    let e = generate(&ProceduralOptions {
        water_fraction: 0.9,
        ..ProceduralOptions::default()
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            LandscapeError::InvalidOption {
                name: "water_fraction",
                ..
            }
        ),
        "{e}"
    );
    assert!(
        generate(&ProceduralOptions {
            width: 0,
            ..ProceduralOptions::default()
        })
        .is_err()
    );
}
