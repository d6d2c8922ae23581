//! PNG stills and animated GIFs, written atomically (`firecast_fs`: hidden temp file, then rename).

use std::borrow::Cow;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::palette;
use crate::{RenderError, RgbImage};

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RenderError + '_ {
    move |source| RenderError::Io {
        source,
        path: path.to_path_buf(),
    }
}

fn fs_err(e: firecast_fs::FsError) -> RenderError {
    RenderError::Io {
        source: e.source,
        path: e.path,
    }
}

/// `image` as 8-bit RGB PNG bytes (the web app serves them without a file).
pub fn encode_png(image: &RgbImage) -> Result<Vec<u8>, RenderError> {
    encode_png_for(image, Path::new("(in memory)"))
}

/// The PNG bytes of `image`; errors name `path`.
fn encode_png_for(image: &RgbImage, path: &Path) -> Result<Vec<u8>, RenderError> {
    let size_err = |message: String| RenderError::Size {
        message,
        path: path.to_path_buf(),
    };
    let (w, h) = (
        u32::try_from(image.width).map_err(|_| size_err(format!("width {} too large", image.width)))?,
        u32::try_from(image.height).map_err(|_| size_err(format!("height {} too large", image.height)))?,
    );
    if w == 0 || h == 0 || image.data.len() != image.width * image.height * 3 {
        return Err(size_err(format!(
            "image {}x{} with {} bytes is not a valid RGB raster",
            image.width,
            image.height,
            image.data.len()
        )));
    }
    let png_err = |source| RenderError::Png {
        source,
        path: path.to_path_buf(),
    };
    let mut bytes = Vec::with_capacity(image.data.len() / 2 + 1024);
    {
        let mut encoder = png::Encoder::new(&mut bytes, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Fast);
        let mut writer = encoder.write_header().map_err(png_err)?;
        writer.write_image_data(&image.data).map_err(png_err)?;
        writer.finish().map_err(png_err)?;
    }
    Ok(bytes)
}

/// Write `image` as an 8-bit RGB PNG at `path`, atomically: a [`firecast_fs::TempPath`] in
/// the same folder, renamed onto `path` once complete (and removed on failure).
pub fn write_png(image: &RgbImage, path: impl AsRef<Path>) -> Result<(), RenderError> {
    let path = path.as_ref();
    let bytes = encode_png_for(image, path)?;
    // Not `firecast_fs::write_atomically`: a missing folder is the caller's error here.
    let tmp = firecast_fs::TempPath::new(path).map_err(fs_err)?;
    let mut file = File::create(tmp.path()).map_err(io_err(tmp.path()))?;
    file.write_all(&bytes)
        .and_then(|()| file.sync_all())
        .map_err(io_err(tmp.path()))?;
    drop(file);
    tmp.publish().map_err(fs_err)
}

/// Levels of the 6 × 7 × 6 colour cube (red, green, blue).
const R_LEVELS: usize = 6;
const G_LEVELS: usize = 7;
const B_LEVELS: usize = 6;
/// Exact colours appended after the 252 cube entries, so opaque overlays stay exact.
const SPECIALS: [[u8; 3]; 4] = [
    palette::FIRE,
    palette::CHARCOAL,
    palette::DROP_RIM,
    palette::LEGEND_BG,
];
/// 4 × 4 Bayer matrix.
const BAYER: [[u8; 4]; 4] = [[0, 8, 2, 10], [12, 4, 14, 6], [3, 11, 1, 9], [15, 7, 13, 5]];

fn level(i: usize, n: usize) -> u8 {
    ((i * 255) as f64 / (n - 1) as f64).round() as u8
}

/// The fixed 256-colour GIF palette: a 6 × 7 × 6 RGB cube (index `r*42 + g*6 + b`)
/// followed by the overlay colours fire, charcoal, drop rim and legend background.
pub fn gif_palette() -> Vec<u8> {
    let mut pal = Vec::with_capacity(256 * 3);
    for r in 0..R_LEVELS {
        for g in 0..G_LEVELS {
            for b in 0..B_LEVELS {
                pal.extend_from_slice(&[level(r, R_LEVELS), level(g, G_LEVELS), level(b, B_LEVELS)]);
            }
        }
    }
    for c in SPECIALS {
        pal.extend_from_slice(&c);
    }
    pal
}

/// Nearest-colour mapping onto [`gif_palette`], optionally with 4 × 4 ordered dithering.
///
/// The cube is a Cartesian product, so its nearest entry is the per-channel nearest level;
/// tables hold that level (already multiplied by the channel's index stride) for each of
/// the 16 dither thresholds and each 8-bit value. Pixels exactly equal to a special colour
/// map to it. Ordered dithering keeps unchanged pixels on the same index frame to frame,
/// which keeps the inter-frame difference rectangles small.
struct Quantizer {
    r: Vec<[u8; 256]>,
    g: Vec<[u8; 256]>,
    b: Vec<[u8; 256]>,
    specials: [u32; SPECIALS.len()],
}

impl Quantizer {
    fn new(dither: bool) -> Self {
        let table = |n: usize, stride: usize| -> Vec<[u8; 256]> {
            let step = 255.0 / (n - 1) as f64;
            (0..16)
                .map(|t| {
                    let off = if dither {
                        ((t as f64 + 0.5) / 16.0 - 0.5) * step
                    } else {
                        0.0
                    };
                    let mut row = [0u8; 256];
                    for (v, slot) in row.iter_mut().enumerate() {
                        let x = (v as f64 + off).clamp(0.0, 255.0);
                        let li = ((x / step).round() as usize).min(n - 1);
                        *slot = (li * stride) as u8;
                    }
                    row
                })
                .collect()
        };
        let pack = |c: [u8; 3]| (u32::from(c[0]) << 16) | (u32::from(c[1]) << 8) | u32::from(c[2]);
        Self {
            r: table(R_LEVELS, G_LEVELS * B_LEVELS),
            g: table(G_LEVELS, B_LEVELS),
            b: table(B_LEVELS, 1),
            specials: SPECIALS.map(pack),
        }
    }

    fn quantize(&self, image: &RgbImage, out: &mut Vec<u8>) {
        out.clear();
        out.reserve(image.width * image.height);
        let cube = (R_LEVELS * G_LEVELS * B_LEVELS) as u8;
        for (y, row) in image.data.chunks_exact(image.width * 3).enumerate() {
            let bayer = &BAYER[y & 3];
            for (x, px) in row.chunks_exact(3).enumerate() {
                let packed = (u32::from(px[0]) << 16) | (u32::from(px[1]) << 8) | u32::from(px[2]);
                if let Some(k) = self.specials.iter().position(|&s| s == packed) {
                    out.push(cube + k as u8);
                    continue;
                }
                let t = usize::from(bayer[x & 3]);
                out.push(
                    self.r[t][usize::from(px[0])]
                        + self.g[t][usize::from(px[1])]
                        + self.b[t][usize::from(px[2])],
                );
            }
        }
    }
}

/// An animated, endlessly looping GIF written frame by frame with a fixed 256-colour
/// palette ([`gif_palette`]). Frames after the first are stored as the rectangle that
/// changed since the previous frame (disposal "keep"), which is much smaller and faster for
/// fire spreading over a static basemap.
///
/// The file is written to a [`firecast_fs::TempPath`] and renamed onto the path by
/// [`GifWriter::finish`]; dropping an unfinished writer deletes the temp file.
pub struct GifWriter {
    path: PathBuf,
    tmp: Option<firecast_fs::TempPath>,
    encoder: Option<gif::Encoder<BufWriter<File>>>,
    width: u16,
    height: u16,
    delay_cs: u16,
    quantizer: Quantizer,
    prev: Vec<u8>,
    cur: Vec<u8>,
    frames: usize,
}

impl std::fmt::Debug for GifWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GifWriter")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("delay_cs", &self.delay_cs)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

impl GifWriter {
    /// Start a GIF of `width × height` pixels at `path`, each frame shown `delay_cs`
    /// hundredths of a second. Ordered dithering is on; see [`GifWriter::create_with`].
    pub fn create(
        path: impl AsRef<Path>,
        width: usize,
        height: usize,
        delay_cs: u16,
    ) -> Result<Self, RenderError> {
        Self::create_with(path, width, height, delay_cs, true)
    }

    /// As [`GifWriter::create`], choosing whether to dither.
    pub fn create_with(
        path: impl AsRef<Path>,
        width: usize,
        height: usize,
        delay_cs: u16,
        dither: bool,
    ) -> Result<Self, RenderError> {
        let path = path.as_ref().to_path_buf();
        let (w, h) = match (u16::try_from(width), u16::try_from(height)) {
            (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
            _ => {
                return Err(RenderError::Size {
                    message: format!("GIF size {width}x{height} must be 1..=65535 on each side"),
                    path,
                });
            }
        };
        let tmp = firecast_fs::TempPath::new(&path).map_err(fs_err)?;
        let file = File::create(tmp.path()).map_err(io_err(tmp.path()))?;
        let gif_err = |source| RenderError::Gif {
            source,
            path: path.clone(),
        };
        let built = gif::Encoder::new(BufWriter::new(file), w, h, &gif_palette())
            .and_then(|mut e| e.set_repeat(gif::Repeat::Infinite).map(|()| e));
        let encoder = match built {
            Ok(e) => e,
            Err(e) => return Err(gif_err(e)),
        };
        Ok(Self {
            path,
            tmp: Some(tmp),
            encoder: Some(encoder),
            width: w,
            height: h,
            delay_cs,
            quantizer: Quantizer::new(dither),
            prev: Vec::new(),
            cur: Vec::new(),
            frames: 0,
        })
    }

    /// Frames added so far.
    pub fn frame_count(&self) -> usize {
        self.frames
    }

    /// Quantise and append one frame; it must have the writer's size.
    pub fn add_frame(&mut self, image: &RgbImage) -> Result<(), RenderError> {
        let (w, h) = (usize::from(self.width), usize::from(self.height));
        if image.width != w || image.height != h || image.data.len() != w * h * 3 {
            return Err(RenderError::Size {
                message: format!(
                    "frame is {}x{} ({} bytes), GIF is {w}x{h}",
                    image.width,
                    image.height,
                    image.data.len()
                ),
                path: self.path.clone(),
            });
        }
        self.quantizer.quantize(image, &mut self.cur);
        // Changed rectangle relative to the previous frame (whole frame for the first).
        let (x0, y0, x1, y1) = if self.frames == 0 {
            (0, 0, w, h)
        } else {
            diff_rect(&self.prev, &self.cur, w, h).unwrap_or((0, 0, 1, 1))
        };
        let buffer: Cow<'_, [u8]> = if (x0, y0, x1, y1) == (0, 0, w, h) {
            Cow::Borrowed(&self.cur)
        } else {
            let mut sub = Vec::with_capacity((x1 - x0) * (y1 - y0));
            for y in y0..y1 {
                sub.extend_from_slice(&self.cur[y * w + x0..y * w + x1]);
            }
            Cow::Owned(sub)
        };
        // Rectangle bounds fit: they are within the u16 canvas.
        let frame = gif::Frame {
            delay: self.delay_cs,
            dispose: gif::DisposalMethod::Keep,
            left: x0 as u16,
            top: y0 as u16,
            width: (x1 - x0) as u16,
            height: (y1 - y0) as u16,
            buffer,
            ..gif::Frame::default()
        };
        let encoder = self.encoder.as_mut().ok_or_else(|| RenderError::Io {
            source: std::io::Error::other("GIF writer already finished"),
            path: self.path.clone(),
        })?;
        encoder.write_frame(&frame).map_err(|source| RenderError::Gif {
            source,
            path: self.path.clone(),
        })?;
        std::mem::swap(&mut self.prev, &mut self.cur);
        self.frames += 1;
        Ok(())
    }

    /// Write the trailer, sync and rename the temp file onto the path. Returns the path.
    pub fn finish(mut self) -> Result<PathBuf, RenderError> {
        let (Some(encoder), Some(tmp)) = (self.encoder.take(), self.tmp.take()) else {
            return Ok(self.path.clone());
        };
        // On any error `tmp` is dropped, which removes the temp file.
        let mut file = encoder.into_inner().map_err(io_err(tmp.path()))?;
        file.flush().map_err(io_err(tmp.path()))?;
        let file = file.into_inner().map_err(|e| RenderError::Io {
            source: e.into_error(),
            path: tmp.path().to_path_buf(),
        })?;
        file.sync_all().map_err(io_err(tmp.path()))?;
        drop(file);
        tmp.publish().map_err(fs_err)?;
        Ok(self.path.clone())
    }
}

impl Drop for GifWriter {
    fn drop(&mut self) {
        // Close the file before its temp name is removed (with `tmp`, after this).
        drop(self.encoder.take());
    }
}

/// Bounding rectangle `(x0, y0, x1, y1)` (exclusive ends) of the pixels that differ.
fn diff_rect(prev: &[u8], cur: &[u8], w: usize, h: usize) -> Option<(usize, usize, usize, usize)> {
    let rows_differ = |y: usize| prev[y * w..(y + 1) * w] != cur[y * w..(y + 1) * w];
    let y0 = (0..h).find(|&y| rows_differ(y))?;
    let y1 = (y0..h).rev().find(|&y| rows_differ(y)).map_or(y0 + 1, |y| y + 1);
    let mut x0 = w;
    let mut x1 = 0;
    for y in y0..y1 {
        let (p, c) = (&prev[y * w..(y + 1) * w], &cur[y * w..(y + 1) * w]);
        if let Some(a) = (0..x0).find(|&x| p[x] != c[x]) {
            x0 = a;
        }
        if let Some(b) = (x1..w).rev().find(|&x| p[x] != c[x]) {
            x1 = b + 1;
        }
    }
    Some((x0, y0, x1.max(x0 + 1), y1))
}
