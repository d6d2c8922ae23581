use std::path::Path;

use firecast_landscape::firecastrl::{
    FireCastRlOptions, PALETTE, class_color, height_ft, load, palette_class, populate_grid, read_png_rgba,
};

fn write_png(path: &Path, w: u32, h: u32, color: png::ColorType, data: &[u8]) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(color);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc.write_header().unwrap();
    wr.write_image_data(data).unwrap();
}

#[test]
fn palette_exact_match() {
    for (k, rgb) in PALETTE {
        assert_eq!(palette_class(rgb), k);
        assert_eq!(class_color(k), Some(rgb));
    }
    assert_eq!(palette_class([0, 0, 254]), 1);
    assert_eq!(palette_class([1, 2, 3]), 1);
    assert_eq!(palette_class([128, 128, 128]), 13);
    assert_eq!(class_color(18), None);
}

#[test]
fn height_decoding() {
    assert_eq!(height_ft(0, 0, 10_000.0), 0.0);
    assert_eq!(height_ft(255, 255, 10_000.0), 10_000.0);
    assert!((height_ft(0x80, 0x01, 10_000.0) - 32769.0 / 65535.0 * 10_000.0).abs() < 1e-9);
}

#[test]
fn land_cover_png_nearest_bottom_up() {
    let dir = tempfile::tempdir().unwrap();
    let (iw, ih) = (10usize, 8usize);
    let class_at = |row: usize, col: usize| -> u16 {
        if (row, col) == (1, 4) {
            0
        } else {
            1 + ((row * 3 + col) % 17) as u16
        }
    };
    let mut data = Vec::new();
    for row in 0..ih {
        for col in 0..iw {
            let rgb = class_color(class_at(row, col)).unwrap_or([9, 9, 9]); // unknown colour
            data.extend_from_slice(&rgb);
        }
    }
    let lc_path = dir.path().join("landcover_1.png");
    write_png(&lc_path, iw as u32, ih as u32, png::ColorType::Rgb, &data);
    // A flat heightmap (RGBA), R=0x40, G=0x00.
    let hm_path = dir.path().join("heightmap_1.png");
    write_png(
        &hm_path,
        4,
        4,
        png::ColorType::Rgba,
        &[0x40, 0, 0, 255].repeat(16),
    );
    let opts = FireCastRlOptions {
        width: 5,
        height: 4,
        fill_terrain_edges: false,
        ..FireCastRlOptions::default()
    };
    let land = load(&lc_path, &hm_path, &opts).unwrap();
    // Steps W/w = 2 and H/h = 2: grid (x, y) ← pixel (row 7 − 2y, col 2x).
    for y in 0..4 {
        for x in 0..5 {
            let want = class_at(7 - 2 * y, 2 * x);
            let want = if want == 0 { 1 } else { want };
            assert_eq!(land.land_cover[y * 5 + x], want, "({x},{y})");
        }
    }
    // Unknown colour at pixel (row 1, col 4) → grid (2, 3) → class 1.
    assert_eq!(land.land_cover[3 * 5 + 2], 1);
    let want = (0x4000 as f64 / 65535.0 * 10_000.0) as f32;
    assert!(land.elevation_ft.iter().all(|&e| (e - want).abs() < 1e-3));
    // Default georef: EPSG:4326 centred on the FireCastRL demo point.
    assert_eq!(land.georef.crs, "EPSG:4326");
    assert_eq!(land.lat_lon_to_cell(34.07022 + 1e-6, -118.54453), Some((2, 2)));
    let (lat, lon) = land.cell_to_lat_lon(2, 1);
    assert!((lon + 118.54453).abs() < 1e-9 && lat < 34.07022, "{lat} {lon}");
}

#[test]
fn heightmap_png_bilinear_and_fill_edges() {
    let dir = tempfile::tempdir().unwrap();
    // 4 × 3 RGBA image, value16 = 1000·(col + 1) + 10_000·row (row 0 top).
    let v = |row: usize, col: usize| (1000 * (col + 1) + 10_000 * row) as u16;
    let mut data = Vec::new();
    for row in 0..3 {
        for col in 0..4 {
            let x = v(row, col);
            data.extend_from_slice(&[(x >> 8) as u8, (x & 0xff) as u8, 77, 255]);
        }
    }
    let hm = dir.path().join("heightmap.png");
    write_png(&hm, 4, 3, png::ColorType::Rgba, &data);
    let lc = dir.path().join("landcover.png");
    write_png(&lc, 1, 1, png::ColorType::Rgb, &[0, 0, 255]);
    let ft = |x: f64| x / 65535.0 * 10_000.0;
    // Grid 3 × 3: column step (4−1)/(3−1) = 1.5, row step (3−1)/(3−1) = 1.
    let opts = FireCastRlOptions {
        width: 3,
        height: 3,
        fill_terrain_edges: false,
        ..FireCastRlOptions::default()
    };
    let land = load(&lc, &hm, &opts).unwrap();
    assert!(land.land_cover.iter().all(|&c| c == 17));
    // Grid row 0 = image row 2 (bottom). x=0 → col 0; x=1 → col 1 + 0.5; x=2 → col 3 (1.5+1.5).
    let e = |x: usize, y: usize| f64::from(land.elevation_ft[y * 3 + x]);
    assert!((e(0, 0) - ft(f64::from(v(2, 0)))).abs() < 1e-2);
    assert!((e(1, 0) - ft((f64::from(v(2, 1)) + f64::from(v(2, 2))) / 2.0)).abs() < 1e-2);
    assert!((e(2, 0) - ft(f64::from(v(2, 3)))).abs() < 1e-2);
    assert!((e(0, 2) - ft(f64::from(v(0, 0)))).abs() < 1e-2);
    // fillTerrainEdges: the outer ring is 0, the centre is untouched.
    let land2 = load(
        &lc,
        &hm,
        &FireCastRlOptions {
            fill_terrain_edges: true,
            ..opts
        },
    )
    .unwrap();
    for y in 0..3 {
        for x in 0..3 {
            let got = land2.elevation_ft[y * 3 + x];
            if (x, y) == (1, 1) {
                assert_eq!(got, land.elevation_ft[4])
            } else {
                assert_eq!(got, 0.0)
            }
        }
    }
}

#[test]
fn populate_grid_matches_firecastrl_steps_for_training_size() {
    // 1200 × 813 image onto 240 × 160: column step 5, row step 813/160.
    let (iw, ih) = (1200usize, 813usize);
    let img: Vec<f64> = (0..iw * ih).map(|i| i as f64).collect();
    let g = populate_grid(240, 160, &img, iw, ih, false);
    assert_eq!(g.len(), 240 * 160);
    assert_eq!(g[0], ((ih - 1) * iw) as f64); // bottom-left pixel
    assert_eq!(g[1], ((ih - 1) * iw + 5) as f64);
    // Row 1: 812 − floor(5.08125) = 807.
    assert_eq!(g[240], (807 * iw) as f64);
    let top_row = (ih as f64 - 1.0 - (159.0f64 * 813.0 / 160.0).floor()) as usize;
    assert_eq!(g[159 * 240] as usize / iw, top_row);
}

#[test]
fn png_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("broken.png");
    std::fs::write(&p, b"nope").unwrap();
    let msg = read_png_rgba(&p).unwrap_err().to_string();
    assert!(msg.starts_with("PNG: ") && msg.ends_with("broken.png"), "{msg}");
}
