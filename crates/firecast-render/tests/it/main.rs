//! Integration tests for firecast-render.
#![allow(clippy::unwrap_used)]

mod chart;

use std::fs::File;
use std::io::BufReader;
use std::path::Path;
use std::time::Instant;

use firecast_landscape::{GeoReference, LandCoverScheme, Landscape};
use firecast_render::palette::{self, FIRE};
use firecast_render::{
    Basemap, FireFrame, GifWriter, RenderOptions, RgbImage, hillshade, render_frame, render_frame_into,
    write_png,
};

fn georef() -> GeoReference {
    GeoReference {
        crs: "EPSG:32611".into(),
        origin_x: 0.0,
        origin_y: 0.0,
        cell_size_x: 152.4,
        cell_size_y: 152.4,
    }
}

fn landscape(w: usize, h: usize, scheme: LandCoverScheme, lc: Vec<u16>, elev: Vec<f32>) -> Landscape {
    Landscape::new(w, h, 500.0, scheme, lc, elev, georef()).unwrap()
}

fn flat(w: usize, h: usize, code: u16) -> Landscape {
    landscape(
        w,
        h,
        LandCoverScheme::ModisIgbp,
        vec![code; w * h],
        vec![1000.0; w * h],
    )
}

/// Pixel at the centre of grid cell (x, y).
fn cell_pixel(b: &Basemap, img: &RgbImage, x: i64, y: i64) -> [u8; 3] {
    let (x0, y0, x1, y1) = b.cell_rect(x, y).unwrap();
    img.pixel((x0 + x1) / 2, (y0 + y1) / 2).unwrap()
}

fn bluish(c: [u8; 3]) -> bool {
    u16::from(c[2]) > u16::from(c[0]) + 60 && u16::from(c[2]) > u16::from(c[1]) + 40
}

fn decode_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let dec = png::Decoder::new(BufReader::new(File::open(path).unwrap()));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

fn tmp_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| firecast_fs::is_temp_name(n))
        .collect()
}

#[test]
fn png_round_trip_fire_and_water() {
    let (w, h) = (20, 10);
    let mut lc = vec![10u16; w * h]; // grassland
    lc[2 * w + 3] = 17; // water at (3, 2)
    let land = landscape(w, h, LandCoverScheme::ModisIgbp, lc, vec![500.0; w * h]);
    let opts = RenderOptions::default();
    let base = Basemap::new(&land, &opts);
    let mut state = vec![0u8; w * h];
    state[5 * w + 10] = 1; // burning at (10, 5)
    state[5 * w + 11] = 2; // burnt at (11, 5)
    let img = render_frame(&base, &FireFrame::new(&state, [-1, -1]), &opts);
    assert_eq!((img.width, img.height), (w * 3, h * 3 + opts.legend_height_px));

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame.png");
    write_png(&img, &path).unwrap();
    let (pw, ph, data) = decode_png(&path);
    assert_eq!((pw as usize, ph as usize), (img.width, img.height));
    assert_eq!(data, img.data);
    let decoded = RgbImage {
        width: pw as usize,
        height: ph as usize,
        data,
    };
    assert_eq!(cell_pixel(&base, &decoded, 10, 5), FIRE);
    let water = cell_pixel(&base, &decoded, 3, 2);
    assert!(bluish(water), "water {water:?}");
    let burnt = cell_pixel(&base, &decoded, 11, 5);
    let grass = cell_pixel(&base, &decoded, 12, 5);
    assert!(burnt.iter().map(|&v| u32::from(v)).sum::<u32>() < grass.iter().map(|&v| u32::from(v)).sum());
    assert!(tmp_files(dir.path()).is_empty());
}

#[test]
fn legend_has_scale_bar_and_swatches() {
    let land = flat(240, 160, 10);
    let opts = RenderOptions::default();
    let base = Basemap::new(&land, &opts);
    assert_eq!(
        (base.width_px(), base.height_px()),
        (720, 480 + opts.legend_height_px)
    );
    let img = &base.image;
    let mid = base.map_height_px + opts.legend_height_px / 2;
    // One mile = 5280 / 500 * 3 = 31.7 px; the bar holds 5 alternating miles.
    let light: Vec<usize> = (0..img.width)
        .filter(|&x| img.pixel(x, mid) == Some([240, 240, 240]))
        .collect();
    let span = light.last().unwrap() - light.first().unwrap();
    assert!((span as f64 - 5.0 * 31.68).abs() < 3.0, "bar spans {span} px");
    assert!((0..img.width).any(|x| img.pixel(x, mid) == Some(FIRE)));
    // Too narrow for a mile: swatches only, no panic.
    let tiny = Basemap::new(&flat(6, 4, 10), &opts);
    assert_eq!(tiny.height_px(), 12 + opts.legend_height_px);
}

#[test]
fn south_row_is_drawn_at_the_bottom() {
    let (w, h) = (8, 6);
    let mut lc = vec![10u16; w * h];
    lc[..w].fill(17); // row 0 (south) is water
    let land = landscape(w, h, LandCoverScheme::ModisIgbp, lc, vec![0.0; w * h]);
    let opts = RenderOptions {
        legend: false,
        ..RenderOptions::default()
    };
    let base = Basemap::new(&land, &opts);
    let img = &base.image;
    assert_eq!(img.height, h * 3);
    assert!(
        bluish(img.pixel(4, img.height - 1).unwrap()),
        "bottom row must be the south (water) row"
    );
    assert!(
        !bluish(img.pixel(4, 0).unwrap()),
        "top row must be the north (grass) row"
    );

    // A burning cell at (0, 0) lands in the bottom-left corner, one at (w-1, h-1) top-right.
    let mut state = vec![0u8; w * h];
    state[0] = 1;
    state[w * h - 1] = 1;
    let frame = render_frame(&base, &FireFrame::new(&state, [-5, -5]), &opts);
    assert_eq!(frame.pixel(0, frame.height - 1), Some(FIRE));
    assert_eq!(frame.pixel(frame.width - 1, 0), Some(FIRE));
    assert_ne!(frame.pixel(0, 0), Some(FIRE));
}

#[test]
fn north_west_facing_slope_is_brighter_than_south_east() {
    let (w, h) = (12, 12);
    // Rises towards the south-east: the slope faces north-west (towards the 315° sun).
    let nw: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x as f32 - y as f32) * 150.0))
        .collect();
    let se: Vec<f32> = nw.iter().map(|z| -z).collect();
    let lc = vec![10u16; w * h];
    let land_nw = landscape(w, h, LandCoverScheme::ModisIgbp, lc.clone(), nw);
    let land_se = landscape(w, h, LandCoverScheme::ModisIgbp, lc, se);
    let s_nw = hillshade(&land_nw, 315.0, 45.0, 1.0);
    let s_se = hillshade(&land_se, 315.0, 45.0, 1.0);
    let s_flat = hillshade(&flat(w, h, 10), 315.0, 45.0, 1.0);
    let c = 6 * w + 6;
    assert!(
        s_nw[c] > s_flat[c] && s_flat[c] > s_se[c],
        "{} {} {}",
        s_nw[c],
        s_flat[c],
        s_se[c]
    );
    assert!((s_flat[c] - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-5);

    let opts = RenderOptions::default();
    let b_nw = Basemap::new(&land_nw, &opts);
    let b_se = Basemap::new(&land_se, &opts);
    let luma = |p: [u8; 3]| p.iter().map(|&v| u32::from(v)).sum::<u32>();
    assert!(luma(cell_pixel(&b_nw, &b_nw.image, 6, 6)) > luma(cell_pixel(&b_se, &b_se.image, 6, 6)));
}

#[test]
fn fuel_model_palettes_are_sensible() {
    let fb13 = landscape(3, 1, LandCoverScheme::Fbfm13, vec![1, 8, 98], vec![0.0; 3]);
    let base = Basemap::new(&fb13, &RenderOptions::default());
    let grass = cell_pixel(&base, &base.image, 0, 0);
    let timber = cell_pixel(&base, &base.image, 1, 0);
    let water = cell_pixel(&base, &base.image, 2, 0);
    assert!(
        grass[0] > 150 && grass[1] > 150 && grass[2] < 120,
        "grass yellow {grass:?}"
    );
    assert!(
        timber[1] > timber[0] && timber[1] > timber[2],
        "timber green {timber:?}"
    );
    assert!(bluish(water), "water {water:?}");
    for code in [101, 122, 145, 163, 185, 202] {
        assert_ne!(
            palette::land_cover_color(LandCoverScheme::Fbfm40, code),
            palette::UNKNOWN
        );
    }
    assert!(bluish(palette::land_cover_color(LandCoverScheme::Fbfm40, 98)));
}

#[test]
fn drops_and_helicopter_are_drawn() {
    let land = flat(40, 30, 10);
    let opts = RenderOptions::default();
    let base = Basemap::new(&land, &opts);
    let state = vec![0u8; 40 * 30];
    let plain = render_frame(&base, &FireFrame::new(&state, [-1, -1]), &opts);
    let drops = [[20, 15]];
    let img = render_frame(&base, &FireFrame::new(&state, [5, 5]).with_drops(&drops), &opts);
    // Inside the disc (3 cells from the centre) the terrain is tinted blue.
    let (a, b) = (cell_pixel(&base, &plain, 23, 15), cell_pixel(&base, &img, 23, 15));
    assert!(b[2] > a[2] + 30, "{a:?} -> {b:?}");
    // Far outside the disc nothing changes.
    assert_eq!(cell_pixel(&base, &plain, 35, 2), cell_pixel(&base, &img, 35, 2));
    assert_eq!(cell_pixel(&base, &img, 5, 5), palette::HELI_BODY);
}

fn gif_frame_count(path: &Path) -> (usize, u16, u16) {
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::RGBA);
    let mut dec = opts.read_info(BufReader::new(File::open(path).unwrap())).unwrap();
    let (w, h) = (dec.width(), dec.height());
    let mut n = 0;
    while let Some(frame) = dec.read_next_frame().unwrap() {
        if n == 0 {
            assert_eq!((frame.width, frame.height), (w, h));
        }
        n += 1;
    }
    (n, w, h)
}

/// Decode a GIF and composite its frames (disposal "keep"), returning the last canvas (RGB)
/// and the frame count.
fn gif_composite(path: &Path) -> (RgbImage, usize) {
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::RGBA);
    let mut dec = opts.read_info(BufReader::new(File::open(path).unwrap())).unwrap();
    let (w, h) = (usize::from(dec.width()), usize::from(dec.height()));
    let mut canvas = RgbImage::new(w, h);
    let mut n = 0;
    while let Some(f) = dec.read_next_frame().unwrap() {
        assert_eq!(f.dispose, gif::DisposalMethod::Keep);
        for y in 0..usize::from(f.height) {
            for x in 0..usize::from(f.width) {
                let i = (y * usize::from(f.width) + x) * 4;
                let c = [f.buffer[i], f.buffer[i + 1], f.buffer[i + 2]];
                canvas.put(usize::from(f.left) + x, usize::from(f.top) + y, c);
            }
        }
        n += 1;
    }
    (canvas, n)
}

fn max_abs_diff(a: &RgbImage, b: &RgbImage) -> u8 {
    a.data
        .iter()
        .zip(&b.data)
        .map(|(&p, &q)| p.abs_diff(q))
        .max()
        .unwrap_or(0)
}

#[test]
fn gif_has_every_frame_and_no_temp_file() {
    let (w, h) = (30, 20);
    let land = flat(w, h, 1);
    let opts = RenderOptions::default();
    let base = Basemap::new(&land, &opts);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.gif");
    let mut gif = GifWriter::create(&path, base.width_px(), base.height_px(), 8).unwrap();
    let mut state = vec![0u8; w * h];
    let mut img = RgbImage::new(0, 0);
    for step in 0..7 {
        if step > 0 && step < 5 {
            state[10 * w + 10 + step] = 1;
            state[10 * w + 9 + step] = 2;
        }
        // Steps 5 and 6 are identical: they must still produce frames.
        let drops = if step == 3 { vec![[12, 10]] } else { vec![] };
        let frame = FireFrame::new(&state, [step as i32, 3]).with_drops(&drops);
        render_frame_into(&base, &frame, &opts, &mut img);
        gif.add_frame(&img).unwrap();
    }
    assert_eq!(gif.frame_count(), 7);
    assert!(!path.exists(), "nothing at the final path before finish");
    assert_eq!(tmp_files(dir.path()).len(), 1);
    assert_eq!(gif.finish().unwrap(), path);
    let (n, gw, gh) = gif_frame_count(&path);
    assert_eq!(n, 7);
    assert_eq!(
        (usize::from(gw), usize::from(gh)),
        (base.width_px(), base.height_px())
    );
    assert!(tmp_files(dir.path()).is_empty());
    // The composited difference rectangles reproduce the last frame within one palette step.
    let (canvas, n2) = gif_composite(&path);
    assert_eq!(n2, 7);
    assert!(
        max_abs_diff(&canvas, &img) <= 51,
        "{}",
        max_abs_diff(&canvas, &img)
    );

    // A wrong-size frame is refused and names the path.
    let mut gif = GifWriter::create(dir.path().join("bad.gif"), 10, 10, 5).unwrap();
    let err = gif.add_frame(&RgbImage::new(11, 10)).unwrap_err();
    assert!(err.to_string().contains("bad.gif"), "{err}");
    // Dropping an unfinished writer leaves neither the GIF nor its temp file.
    drop(gif);
    assert!(!dir.path().join("bad.gif").exists());
    assert!(tmp_files(dir.path()).is_empty());
}

#[test]
fn gif_keeps_overlay_colours_exact() {
    let land = flat(10, 10, 10);
    let opts = RenderOptions::default();
    let base = Basemap::new(&land, &opts);
    let mut state = vec![0u8; 100];
    state[55] = 1;
    let img = render_frame(&base, &FireFrame::new(&state, [-1, -1]), &opts);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("one.gif");
    let mut gif = GifWriter::create(&path, img.width, img.height, 10).unwrap();
    gif.add_frame(&img).unwrap();
    gif.finish().unwrap();
    let mut dopts = gif::DecodeOptions::new();
    dopts.set_color_output(gif::ColorOutput::RGBA);
    let mut dec = dopts
        .read_info(BufReader::new(File::open(&path).unwrap()))
        .unwrap();
    let frame = dec.read_next_frame().unwrap().unwrap();
    let (x0, y0, _, _) = base.cell_rect(5, 5).unwrap();
    let i = (y0 * img.width + x0) * 4;
    assert_eq!(&frame.buffer[i..i + 3], &FIRE);
}

#[test]
fn write_errors_name_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("missing-dir").join("x.png");
    let err = write_png(&RgbImage::new(4, 4), &path).unwrap_err();
    assert!(err.to_string().contains("missing-dir"), "{err}");
    let err = write_png(&RgbImage::new(0, 4), dir.path().join("empty.png")).unwrap_err();
    assert!(err.to_string().contains("empty.png"), "{err}");
}

/// Timing of a 240 × 160 grid at 3 px/cell (720 × 480 map): `cargo test -p firecast-render
/// --release -- --ignored --nocapture bench`.
#[test]
#[ignore]
fn bench_render_and_gif_720x480() {
    let (w, h) = (240, 160);
    let elev: Vec<f32> = (0..h)
        .flat_map(|y| {
            (0..w).map(move |x| 3000.0 + 1500.0 * ((x as f32 / 17.0).sin() * (y as f32 / 23.0).cos()))
        })
        .collect();
    let lc: Vec<u16> = (0..w * h)
        .map(|i| (((i / w) / 20 + (i % w) / 30) % 17 + 1) as u16)
        .collect();
    let land = landscape(w, h, LandCoverScheme::ModisIgbp, lc, elev);
    let opts = RenderOptions {
        legend: false,
        ..RenderOptions::default()
    };
    let t = Instant::now();
    let base = Basemap::new(&land, &opts);
    let basemap_ms = t.elapsed().as_secs_f64() * 1e3;
    assert_eq!((base.width_px(), base.height_px()), (720, 480));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bench.gif");
    let mut gif = GifWriter::create(&path, 720, 480, 5).unwrap();
    let mut state = vec![0u8; w * h];
    let mut img = RgbImage::new(0, 0);
    let (mut render_s, mut gif_s) = (0.0, 0.0);
    let frames = 300;
    for step in 0..frames {
        // A growing fire: a ring of burning cells around a burnt disc.
        let r = step as f64 * 0.25;
        for y in 0..h {
            for x in 0..w {
                let d = ((x as f64 - 120.0).powi(2) + (y as f64 - 80.0).powi(2)).sqrt();
                state[y * w + x] = if d < r - 2.0 {
                    2
                } else if d < r {
                    1
                } else {
                    0
                };
            }
        }
        let drops = if step % 10 == 0 {
            vec![[120 + (r as i32), 80]]
        } else {
            vec![]
        };
        let heli = [120 + step % 60, 100];
        let t = Instant::now();
        render_frame_into(
            &base,
            &FireFrame::new(&state, heli).with_drops(&drops),
            &opts,
            &mut img,
        );
        render_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        gif.add_frame(&img).unwrap();
        gif_s += t.elapsed().as_secs_f64();
    }
    let t = Instant::now();
    gif.finish().unwrap();
    let finish_ms = t.elapsed().as_secs_f64() * 1e3;
    let size = std::fs::metadata(&path).unwrap().len();
    let (canvas, n) = gif_composite(&path);
    assert_eq!(n, frames as usize);
    assert!(max_abs_diff(&canvas, &img) <= 51);
    write_png(&img, dir.path().join("last.png")).unwrap();
    if let Ok(keep) = std::env::var("FIRECAST_RENDER_BENCH_OUT") {
        std::fs::copy(&path, Path::new(&keep).join("bench.gif")).unwrap();
        std::fs::copy(dir.path().join("last.png"), Path::new(&keep).join("last.png")).unwrap();
        let (canvas, _) = gif_composite(&path);
        let with_legend = RenderOptions::default();
        let b2 = Basemap::new(&land, &with_legend);
        let f2 = render_frame(
            &b2,
            &FireFrame::new(&state, [150, 60]).with_drops(&[[100, 80]]),
            &with_legend,
        );
        write_png(&f2, Path::new(&keep).join("legend.png")).unwrap();
        write_png(&canvas, Path::new(&keep).join("last_from_gif.png")).unwrap();
    }
    println!(
        "basemap {basemap_ms:.1} ms; per frame: render {:.2} ms, gif quantise+encode {:.2} ms; \
         finish {finish_ms:.1} ms; {frames} frames -> {:.1} MB",
        render_s * 1e3 / f64::from(frames),
        gif_s * 1e3 / f64::from(frames),
        size as f64 / 1e6
    );
}
