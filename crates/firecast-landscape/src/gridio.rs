//! Float32 GeoTIFF grids: encoding one band with a copied georeference, and reading back a
//! band's values from TIFFs that carry no GeoKeys (FlamMap's outputs).
//!
//! The encoder writes a baseline little-endian TIFF (one uncompressed strip per row,
//! SampleFormat IEEE float, MinIsBlack) with ModelPixelScaleTag (33550), ModelTiepointTag
//! (33922; the outer corner of pixel (0, 0), or its centre when the GeoKeys say PixelIsPoint),
//! the input's GeoKeyDirectoryTag (34735), GeoDoubleParamsTag (34736) and GeoAsciiParamsTag
//! (34737) unchanged, and GDAL_NODATA (42113) as ASCII. GDAL, rasterio and the repository's
//! own reader ([`crate::geotiff::read_geotiff`]) read it.

use std::fs::File;
use std::io::{BufReader, Cursor};
use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult};
use tiff::encoder::{TiffEncoder, colortype::Gray32Float};
use tiff::tags::Tag;

use crate::LandscapeError;

/// The raw GeoTIFF key tags of a file, copied verbatim into written grids.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GeoKeyTags {
    pub directory: Vec<u16>,
    pub doubles: Vec<f64>,
    pub ascii: String,
}

fn fmt_err(path: &Path, e: impl std::fmt::Display) -> LandscapeError {
    LandscapeError::Format {
        format: "TIFF",
        message: e.to_string(),
        path: path.to_path_buf(),
    }
}

impl GeoKeyTags {
    /// Read the key tags of `path` (empty where absent).
    pub fn read(path: &Path) -> Result<Self, LandscapeError> {
        let file = File::open(path).map_err(|source| LandscapeError::Io {
            source,
            path: path.to_path_buf(),
        })?;
        let mut dec = Decoder::new(BufReader::new(file)).map_err(|e| fmt_err(path, e))?;
        let directory = match dec
            .find_tag(Tag::GeoKeyDirectoryTag)
            .map_err(|e| fmt_err(path, e))?
        {
            Some(v) => v.into_u16_vec().map_err(|e| fmt_err(path, e))?,
            None => Vec::new(),
        };
        let doubles = match dec
            .find_tag(Tag::GeoDoubleParamsTag)
            .map_err(|e| fmt_err(path, e))?
        {
            Some(v) => v.into_f64_vec().map_err(|e| fmt_err(path, e))?,
            None => Vec::new(),
        };
        let ascii = match dec
            .find_tag(Tag::GeoAsciiParamsTag)
            .map_err(|e| fmt_err(path, e))?
        {
            Some(v) => v.into_string().map_err(|e| fmt_err(path, e))?,
            None => String::new(),
        };
        Ok(Self {
            directory,
            doubles,
            ascii,
        })
    }

    /// Whether GTRasterTypeGeoKey (1025) says PixelIsPoint (2).
    fn pixel_is_point(&self) -> bool {
        self.directory
            .get(4..)
            .unwrap_or_default()
            .chunks_exact(4)
            .any(|k| k[0] == 1025 && k[1] == 0 && k[3] == 2)
    }
}

/// Where a written grid sits: the outer corner of pixel (0, 0) and the pixel size (CRS units;
/// `pixel_dy < 0` for north-up).
#[derive(Debug, Clone, PartialEq)]
pub struct GridPlacement {
    pub width: usize,
    pub height: usize,
    pub origin_x: f64,
    pub origin_y: f64,
    pub pixel_dx: f64,
    pub pixel_dy: f64,
    pub geokeys: GeoKeyTags,
}

/// Encode one float32 band (row 0 north) as a GeoTIFF.
pub fn encode_geotiff_f32(
    placement: &GridPlacement,
    data: &[f32],
    nodata: Option<f64>,
) -> Result<Vec<u8>, LandscapeError> {
    let (w, h) = (placement.width, placement.height);
    let err = |e: tiff::TiffError| LandscapeError::Format {
        format: "TIFF",
        message: format!("encoding a {w} x {h} float32 grid: {e}"),
        path: std::path::PathBuf::from("<memory>"),
    };
    if data.len() != w * h || w == 0 || h == 0 {
        return Err(LandscapeError::LayerSize {
            layer: "grid",
            got: data.len(),
            width: w,
            height: h,
            expected: w * h,
        });
    }
    let mut bytes = Cursor::new(Vec::with_capacity(data.len() * 4 + 4096));
    {
        let mut enc = TiffEncoder::new(&mut bytes).map_err(err)?;
        let mut image = enc.new_image::<Gray32Float>(w as u32, h as u32).map_err(err)?;
        image.rows_per_strip(1).map_err(err)?;
        let (tx, ty) = if placement.geokeys.pixel_is_point() {
            (
                placement.origin_x + 0.5 * placement.pixel_dx,
                placement.origin_y + 0.5 * placement.pixel_dy,
            )
        } else {
            (placement.origin_x, placement.origin_y)
        };
        let dir = image.encoder();
        dir.write_tag(
            Tag::ModelPixelScaleTag,
            &[placement.pixel_dx.abs(), placement.pixel_dy.abs(), 0.0][..],
        )
        .map_err(err)?;
        dir.write_tag(Tag::ModelTiepointTag, &[0.0, 0.0, 0.0, tx, ty, 0.0][..])
            .map_err(err)?;
        if !placement.geokeys.directory.is_empty() {
            dir.write_tag(Tag::GeoKeyDirectoryTag, &placement.geokeys.directory[..])
                .map_err(err)?;
        }
        if !placement.geokeys.doubles.is_empty() {
            dir.write_tag(Tag::GeoDoubleParamsTag, &placement.geokeys.doubles[..])
                .map_err(err)?;
        }
        if !placement.geokeys.ascii.is_empty() {
            dir.write_tag(Tag::GeoAsciiParamsTag, placement.geokeys.ascii.as_str())
                .map_err(err)?;
        }
        if let Some(nd) = nodata {
            dir.write_tag(Tag::Unknown(42113), format!("{nd}").as_str())
                .map_err(err)?;
        }
        image.write_data(data).map_err(err)?;
    }
    Ok(bytes.into_inner())
}

/// The first band of a single-band TIFF as f32, with its size, whatever its tags (no
/// georeference needed).
pub fn read_band_f32(path: &Path) -> Result<(usize, usize, Vec<f32>), LandscapeError> {
    let file = File::open(path).map_err(|source| LandscapeError::Io {
        source,
        path: path.to_path_buf(),
    })?;
    let mut dec = Decoder::new(BufReader::new(file)).map_err(|e| fmt_err(path, e))?;
    let (w, h) = dec.dimensions().map_err(|e| fmt_err(path, e))?;
    let values: Vec<f32> = match dec.read_image().map_err(|e| fmt_err(path, e))? {
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I32(v) => v.into_iter().map(|x| x as f32).collect(),
        _ => return Err(fmt_err(path, "unsupported sample type")),
    };
    if values.len() != (w as usize) * (h as usize) {
        return Err(fmt_err(path, "not a single-band image"));
    }
    Ok((w as usize, h as usize, values))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_grid_reads_back_with_its_georeference() {
        let placement = GridPlacement {
            width: 3,
            height: 2,
            origin_x: 1_833_825.0,
            origin_y: 2_617_605.0,
            pixel_dx: 30.0,
            pixel_dy: -30.0,
            geokeys: GeoKeyTags {
                directory: vec![1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 5070],
                doubles: Vec::new(),
                ascii: String::new(),
            },
        };
        let data = [0.0, 1.5, -9999.0, 3.25, f32::MAX, 7.0];
        let bytes = encode_geotiff_f32(&placement, &data, Some(-9999.0)).expect("encodes");
        let dir = std::env::temp_dir().join(format!("firecast-gridio-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("g.tif");
        std::fs::write(&path, bytes).expect("write");
        let raster = crate::geotiff::read_geotiff(&path).expect("reads");
        assert_eq!((raster.width, raster.height), (3, 2));
        assert_eq!(raster.crs, "EPSG:5070");
        assert_eq!(raster.nodata, Some(-9999.0));
        assert_eq!((raster.origin_x, raster.origin_y), (1_833_825.0, 2_617_605.0));
        assert_eq!((raster.pixel_dx, raster.pixel_dy), (30.0, -30.0));
        assert_eq!(raster.data, data);
        assert_eq!(raster.sample_type, crate::geotiff::SampleType::F32);
        let (w, h, band) = read_band_f32(&path).expect("band");
        assert_eq!((w, h, band.as_slice()), (3, 2, &data[..]));
        std::fs::remove_dir_all(&dir).ok();
    }
}
