//! Shared resampling plumbing: grid cell centres in a raster's CRS, and elevation nodata fill.

use std::collections::VecDeque;
use std::path::Path;

use crate::LandscapeError;
use crate::georef::{Crs, GridSpec};

/// What to do with grid cells that end up without elevation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ElevationNoData {
    /// Copy the nearest valid grid cell (8-connected breadth-first fill).
    #[default]
    NearestValid,
    /// Fail with [`crate::LandscapeError::ElevationNoData`].
    Error,
}

/// For each grid cell (row-major, row 0 south), its centre in `raster_crs` coordinates
/// (`None` where the transform fails).
pub(crate) fn raster_points(
    grid: &GridSpec,
    raster_crs: &str,
    path: &Path,
) -> Result<Vec<Option<(f64, f64)>>, LandscapeError> {
    let same = grid.georef.crs.trim().eq_ignore_ascii_case(raster_crs.trim());
    let (gc, rc) = (Crs::parse(&grid.georef.crs), Crs::parse(raster_crs));
    if !same && gc != rc && !(gc.is_supported() && rc.is_supported()) {
        return Err(LandscapeError::CrsMismatch {
            grid: grid.georef.crs.clone(),
            raster: raster_crs.to_string(),
            path: path.to_path_buf(),
        });
    }
    let identity = same || gc == rc;
    let mut out = Vec::with_capacity(grid.width * grid.height);
    for y in 0..grid.height {
        for x in 0..grid.width {
            let (cx, cy) = grid.cell_center(x, y);
            out.push(if identity {
                Some((cx, cy))
            } else {
                gc.to_lat_lon(cx, cy)
                    .and_then(|(lat, lon)| rc.from_lat_lon(lat, lon))
            });
        }
    }
    Ok(out)
}

/// Apply the elevation nodata policy to per-cell optional values.
pub(crate) fn finish_elevation(
    cells: Vec<Option<f32>>,
    width: usize,
    policy: ElevationNoData,
    path: &Path,
) -> Result<Vec<f32>, LandscapeError> {
    let missing: Vec<usize> = cells
        .iter()
        .enumerate()
        .filter(|(_, v)| v.is_none())
        .map(|(i, _)| i)
        .collect();
    if missing.len() == cells.len() {
        return Err(LandscapeError::NoOverlap {
            layer: "elevation",
            path: path.to_path_buf(),
        });
    }
    if let (Some(&first), ElevationNoData::Error) = (missing.first(), policy) {
        return Err(LandscapeError::ElevationNoData {
            count: missing.len(),
            x: first % width,
            y: first / width,
            path: path.to_path_buf(),
        });
    }
    Ok(fill_nearest(cells, width))
}

/// 8-connected multi-source breadth-first fill of `None` cells from the nearest valid cells.
pub(crate) fn fill_nearest(mut cells: Vec<Option<f32>>, width: usize) -> Vec<f32> {
    let height = cells.len() / width.max(1);
    let mut queue: VecDeque<usize> = (0..cells.len()).filter(|&i| cells[i].is_some()).collect();
    while let Some(i) = queue.pop_front() {
        let v = cells[i];
        let (x, y) = ((i % width) as isize, (i / width) as isize);
        for (dx, dy) in [
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (1, -1),
            (-1, 1),
            (-1, -1),
        ] {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= width as isize || ny >= height as isize {
                continue;
            }
            let j = ny as usize * width + nx as usize;
            if cells[j].is_none() {
                cells[j] = v;
                queue.push_back(j);
            }
        }
    }
    cells.into_iter().map(|v| v.unwrap_or(0.0)).collect()
}
