//! Ensembles on a real LANDFIRE landscape (the Worcester, Vermont clip): a window cut around a
//! place, both engines, the label, the .lcp and GeoTIFF forms of the same cells, bad input.

use std::path::{Path, PathBuf};

use firecast_episodes::ensemble::{Ensemble, Perturbation, Setup, run_agent};
use firecast_episodes::free_spread::run_mtt;
use firecast_episodes::landfire::FuelLayerName;
use firecast_episodes::{AgentKind, LandscapeSpec, Scenario};
use firecast_landscape::Crs;

fn fixture(rel: &str) -> PathBuf {
    std::path::PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| env!("CARGO_MANIFEST_DIR").into()),
    )
    .join("../firecast-landscape/tests/fixtures/landfire-worcester")
    .join(rel)
}

/// Latitude and longitude of the centre of the clip's cell (`col`, `row`), row 0 north (the
/// clip's north-west corner is at 1,833,825 E, 2,617,605 N in EPSG:5070, cells of 30 m).
fn lat_lon(col: usize, row: usize) -> [f64; 2] {
    let x = 1_833_825.0 + (col as f64 + 0.5) * 30.0;
    let y = 2_617_605.0 - (row as f64 + 0.5) * 30.0;
    let (lat, lon) = Crs::parse("EPSG:5070").to_lat_lon(x, y).unwrap();
    [lat, lon]
}

fn landfire(path: PathBuf, center: Option<[f64; 2]>, size: Option<[usize; 2]>) -> LandscapeSpec {
    LandscapeSpec::Landfire {
        path,
        fuel: FuelLayerName::Fbfm40,
        center,
        width: size.map(|s| s[0]),
        height: size.map(|s| s[1]),
        site: None,
    }
}

fn scenario(landscape: LandscapeSpec, hours: u32) -> Scenario {
    let mut env = firecast_sim::EnvConfig::default();
    env.sim.kernel = firecast_sim::KernelConfig::rothermel_default();
    env.sim.wind.speed_mph = 15.0;
    env.sim.wind.from_direction_deg = 250.0;
    env.sim.wind.measured_at = firecast_sim::WindHeight::TwentyFoot;
    env.max_steps = (f64::from(hours) * 60.0 / env.sim.dt_min).round() as u32;
    Scenario::new(landscape, env)
}

fn burnt_cells_are_burnable(e: &Ensemble) -> usize {
    let mut burnt = 0;
    for (i, &n) in e.burn_count.iter().enumerate() {
        if n > 0 {
            burnt += 1;
            let code = e.land_cover[i];
            assert!(
                firecast_sim::FuelModel::by_number(code).is_some_and(|m| m.burnable),
                "cell {i} burnt on fuel code {code}"
            );
        }
    }
    burnt
}

/// An 80 × 60 window of the clip around a grass cell: both engines burn only burnable fuel,
/// and the label says the landscape is LANDFIRE's, names its files and counts every cell.
#[test]
fn ensembles_run_on_a_landfire_window_and_burn_only_fuel() {
    let root = Path::new(".");
    let ignition = lat_lon(52, 100);
    let spec = landfire(fixture("landfire"), Some(lat_lon(60, 105)), Some([80, 60]));
    let setup = Setup::new(scenario(spec, 8), root, Some(ignition))
        .unwrap()
        .with_perturbation(Perturbation::default());
    let land = &setup.landscape;
    assert_eq!((land.width, land.height), (80, 60));
    assert!((land.cell_size_ft - 30.0 / 0.3048).abs() < 1e-9);
    // The window is columns 20..100, rows 75..135 of the clip: the ignition is its cell (32, 34).
    assert_eq!(setup.ignition, [52 - 20, 60 - 1 - (100 - 75)]);
    assert_eq!(
        land.land_cover[land.index(32, 34)],
        102,
        "GR2 at column 52, row 100"
    );

    let automaton = run_agent(&setup, AgentKind::None, 2, 0, |_| {}).unwrap();
    let mtt = run_mtt(&setup, 2, 0, |_| {}).unwrap();
    for e in [&automaton, &mtt] {
        let burnt = burnt_cells_are_burnable(e);
        assert!(burnt > 20, "{burnt} cells burnt in 8 h");
        let label = e.landscape.as_ref().unwrap();
        assert_eq!(label.kind, "landfire");
        assert!(!label.synthetic);
        assert!(
            label.sources.iter().any(|s| s.ends_with("LC22_F40_230.tif")),
            "{label:?}"
        );
        assert!(
            label.sources.iter().any(|s| s.ends_with("LC20_Elev_220.tif")),
            "{label:?}"
        );
        let c = label.fuel_cells.as_ref().unwrap();
        let nonburnable: u64 = c.nonburnable.values().sum();
        assert_eq!(c.burnable + nonburnable + c.fuel_nodata, 80 * 60);
        assert!(c.fuel_nodata > 0 && nonburnable > 0, "{c:?}");
        // The clip's nodata is one mask in every layer.
        assert_eq!(c.elevation_nodata, c.fuel_nodata);
        assert_eq!(c.unknown_codes, 0);
        assert_eq!(
            land.land_cover.iter().filter(|&&code| code == 99).count() as u64,
            c.fuel_nodata + c.nonburnable.get(&99).copied().unwrap_or(0)
        );
        for words in [
            "LANDFIRE landscape",
            "LC22_F40_230.tif",
            "from column 20, row 75",
            "without fuel data",
        ] {
            assert!(label.note.contains(words), "{words}: {}", label.note);
        }
        assert_eq!(e.grid.crs, "EPSG:5070");
        assert_eq!(e.grid.scheme, "fbfm40");
        let [lat, lon] = e.ignition_lat_lon;
        assert!((lat - ignition[0]).abs() < 1e-6 && (lon - ignition[1]).abs() < 1e-6);
    }
}

/// The .lcp fixture is the clip's 48 × 40 cells from column 70, row 400, written by GDAL: the
/// GeoTIFF layers cut around the same cells give the same landscape and the same fires (the
/// MTT engine's arrival times within the .lcp's slope rounding).
#[test]
fn the_lcp_and_the_geotiff_layers_give_the_same_fires() {
    let root = Path::new(".");
    let lcp = landfire(fixture("lcp/worcester_crop.lcp"), None, None);
    let tif = landfire(
        fixture("landfire"),
        Some(lat_lon(70 + 24, 400 + 20)),
        Some([48, 40]),
    );
    let a = Setup::new(scenario(lcp, 6), root, None).unwrap();
    let b = Setup::new(scenario(tif, 6), root, None).unwrap();
    assert_eq!(a.landscape.land_cover, b.landscape.land_cover);
    assert_eq!(a.landscape.elevation_ft, b.landscape.elevation_ft);
    assert_eq!(a.landscape.georef, b.landscape.georef);
    assert_eq!(a.ignition, b.ignition);
    let la = a.scenario.landscape.label();
    let lb = b.scenario.landscape.label();
    assert_eq!(la.fuel_cells, lb.fuel_cells);
    assert!(la.fuel_cells.as_ref().unwrap().fuel_nodata > 300, "{la:?}");
    assert!(
        la.note.contains("FARSITE .lcp") && la.note.contains("worcester_crop.lcp"),
        "{}",
        la.note
    );
    assert!(
        la.sources.iter().any(|s| s.ends_with("worcester_crop.prj")),
        "{la:?}"
    );
    assert!(lb.note.contains("LANDFIRE GeoTIFF layers"), "{}", lb.note);
    let same = |x: Ensemble, y: Ensemble| {
        assert_eq!(x.episodes, y.episodes);
        assert_eq!(x.burn_count, y.burn_count);
        assert_eq!(x.arrival_first_h, y.arrival_first_h);
        burnt_cells_are_burnable(&x)
    };
    let burnt = same(
        run_agent(&a, AgentKind::None, 2, 3, |_| {}).unwrap(),
        run_agent(&b, AgentKind::None, 2, 3, |_| {}).unwrap(),
    );
    assert!(burnt > 5, "{burnt}");
    // The MTT engine spreads over the window's own slope layer, which the .lcp stores in whole
    // degrees (the GeoTIFF in percent): the same cells burn, at times within 5 %.
    let (x, y) = (
        run_mtt(&a, 2, 3, |_| {}).unwrap(),
        run_mtt(&b, 2, 3, |_| {}).unwrap(),
    );
    assert_eq!(x.burn_count, y.burn_count);
    for (p, q) in x.arrival_first_h.iter().zip(&y.arrival_first_h) {
        match (p, q) {
            (Some(p), Some(q)) => assert!((p - q).abs() <= 0.05 * p.max(*q) + 1e-6, "{p} h vs {q} h"),
            (p, q) => assert_eq!(p, q),
        }
    }
    let burnt = burnt_cells_are_burnable(&x);
    assert!(burnt > 5, "{burnt}");
}

/// The MTT engine over the window's own slope, aspect and canopy (what the free-spread ensemble
/// can call instead of the elevation-derived slope): the fire starts at the ignition, burns only
/// burnable cells, and a midflame wind (which FlamMap's adjustment cannot take) gives None.
#[test]
fn the_mtt_engine_runs_on_the_windows_own_layers() {
    use firecast_spread::mtt::{DEFAULT_STENCIL_RADIUS, MttConfig};
    let spec = landfire(fixture("landfire"), Some(lat_lon(60, 105)), Some([80, 60]));
    let setup = Setup::new(scenario(spec, 8), Path::new("."), Some(lat_lon(52, 100))).unwrap();
    let site = setup.scenario.landscape.landfire_site().unwrap();
    let env = setup.env();
    let firecast_sim::KernelConfig::Rothermel { moisture, .. } = env.sim.kernel else {
        unreachable!()
    };
    let mut cfg = MttConfig {
        moisture,
        wind: env.sim.wind,
        stencil_radius: DEFAULT_STENCIL_RADIUS,
        max_time_h: 8.0,
    };
    let [x, y] = setup.ignition;
    let arrival = site.mtt_arrival_h(&cfg, (x, y)).unwrap().unwrap();
    let land = &setup.landscape;
    assert_eq!(arrival.len(), land.len());
    assert_eq!(arrival[land.index(x, y)], 0.0);
    let burnt: Vec<usize> = (0..arrival.len()).filter(|&i| arrival[i] <= 8.0).collect();
    assert!(burnt.len() > 20, "{} cells in 8 h", burnt.len());
    for &i in &burnt {
        let code = land.land_cover[i];
        assert!(
            firecast_sim::FuelModel::by_number(code).is_some_and(|m| m.burnable),
            "cell {i} burnt on fuel code {code}"
        );
    }
    cfg.wind.measured_at = firecast_sim::WindHeight::Midflame;
    assert_eq!(site.mtt_arrival_h(&cfg, (x, y)).unwrap(), None);
}

fn setup_error(spec: LandscapeSpec, ignition: Option<[f64; 2]>) -> String {
    match Setup::new(scenario(spec, 1), Path::new("."), ignition) {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_places_name_the_key_and_the_cell() {
    let window = || landfire(fixture("landfire"), Some(lat_lon(60, 105)), Some([80, 60]));
    // An ignition off the window.
    let e = setup_error(window(), Some(lat_lon(300, 300)));
    assert!(
        e.starts_with("ignition: ") && e.contains("outside the landscape"),
        "{e}"
    );
    // Nodata and non-burnable fuel at the ignition name the clip's cell and the file.
    let e = setup_error(window(), Some(lat_lon(30, 80)));
    assert!(
        e.contains("nodata") && e.contains("column 30, row 80") && e.contains("LC22_F40_230.tif"),
        "{e}"
    );
    let e = setup_error(window(), Some(lat_lon(68, 89)));
    assert!(
        e.contains("non-burnable fuel code 91") && e.contains("column 68, row 89"),
        "{e}"
    );
    // A center off the grid names the key and the grid.
    let e = setup_error(landfire(fixture("landfire"), Some([40.0, -100.0]), None), None);
    assert!(
        e.contains("center (40, -100) is outside the LANDFIRE grid (549 x 613"),
        "{e}"
    );
    let e = setup_error(landfire(fixture("landfire"), None, Some([10, 10])), None);
    assert!(e.contains("give center too"), "{e}");
    // The reader's own errors come through, naming the file.
    let e = setup_error(landfire(fixture("nowhere"), None, None), None);
    assert!(e.contains("nowhere"), "{e}");
    let mut spec = window();
    if let LandscapeSpec::Landfire { fuel, .. } = &mut spec {
        *fuel = FuelLayerName::Fbfm13;
    }
    assert!(
        Setup::new(scenario(spec, 1), Path::new("."), Some(lat_lon(52, 100))).is_ok(),
        "FBFM13 reads"
    );
}

/// Scenario files take the same landscape kind, strictly.
#[test]
fn scenario_files_name_a_landfire_landscape() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scenario.yaml");
    std::fs::write(
        &path,
        "landscape: {landfire: {path: some/dir, center: [44.4, -72.6], width: 10}}\n",
    )
    .unwrap();
    let s = Scenario::from_file(&path).unwrap();
    assert!(matches!(
        s.landscape,
        LandscapeSpec::Landfire {
            width: Some(10),
            height: None,
            site: None,
            ..
        }
    ));
    std::fs::write(&path, "landscape: {landfire: {path: x, site: 1}}\n").unwrap();
    let err = Scenario::from_file(&path).unwrap_err().to_string();
    assert!(err.contains("unknown field `site`"), "{err}");
}
