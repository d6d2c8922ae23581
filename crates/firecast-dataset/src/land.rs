//! The land mask: GRIDMET's valid-data cells. GRIDMET is masked over the ocean, the Great
//! Lakes, Canada and Mexico, so "has weather data" stands in for the authors' Natural Earth
//! USA polygon without shipping a shapefile — and it is exactly the condition a sample needs
//! to get a weather window at all.

use std::path::{Path, PathBuf};

use firecast_data::gridmet::GridmetFile;

use crate::DatasetError;

/// Valid-data cells of a GRIDMET grid.
#[derive(Debug, Clone)]
pub struct LandMask {
    lats: Vec<f64>,
    lons: Vec<f64>,
    valid: Vec<bool>,
    source: PathBuf,
}

impl LandMask {
    /// The cells with data on the first day of `file`.
    pub fn from_gridmet_file(file: &GridmetFile) -> Result<Self, DatasetError> {
        let day = file.read_day(0)?;
        Ok(Self {
            lats: file.lats().to_vec(),
            lons: file.lons().to_vec(),
            valid: day.iter().map(|v| v.is_finite()).collect(),
            source: file.path().to_path_buf(),
        })
    }

    /// The mask of the first GRIDMET file (by name) in `dir`.
    pub fn from_gridmet_dir(dir: &Path) -> Result<Self, DatasetError> {
        let files = crate::windows::list_gridmet_files(dir)?;
        let Some(first) = files.into_iter().next() else {
            return Err(DatasetError::Input {
                path: dir.to_path_buf(),
                message: "no GRIDMET files (<short>_<YYYY>.nc) in this directory".into(),
            });
        };
        Self::from_gridmet_file(&GridmetFile::open(&first.path, first.variable)?)
    }

    /// A mask from explicit axes (row-major `[lat][lon]`), for tests and synthetic grids.
    pub fn from_grid(lats: Vec<f64>, lons: Vec<f64>, valid: Vec<bool>) -> Self {
        assert_eq!(lats.len() * lons.len(), valid.len(), "mask size");
        Self {
            lats,
            lons,
            valid,
            source: PathBuf::from("<memory>"),
        }
    }

    /// The file the mask came from.
    pub fn source(&self) -> &Path {
        &self.source
    }

    /// Whether the nearest cell (within half a cell of the grid) has data.
    pub fn on_land(&self, lat: f64, lon: f64) -> bool {
        match (nearest(&self.lats, lat), nearest(&self.lons, lon)) {
            (Some(j), Some(i)) => self.valid[j * self.lons.len() + i],
            _ => false,
        }
    }

    /// Cells with data.
    pub fn land_cells(&self) -> usize {
        self.valid.iter().filter(|v| **v).count()
    }

    /// Latitude centres (as stored).
    pub fn lats(&self) -> &[f64] {
        &self.lats
    }

    /// Longitude centres.
    pub fn lons(&self) -> &[f64] {
        &self.lons
    }

    /// Whether cell `(j, i)` has data.
    pub fn is_valid(&self, j: usize, i: usize) -> bool {
        self.valid[j * self.lons.len() + i]
    }
}

/// Nearest index on a regular (ascending or descending) axis; `None` beyond half a cell.
fn nearest(axis: &[f64], x: f64) -> Option<usize> {
    if axis.is_empty() || !x.is_finite() {
        return None;
    }
    if axis.len() == 1 {
        return Some(0);
    }
    let step = (axis[axis.len() - 1] - axis[0]) / (axis.len() - 1) as f64;
    let k = ((x - axis[0]) / step).round();
    if k < 0.0 || k > (axis.len() - 1) as f64 {
        // Exactly half a cell out rounds away; allow the edge cell's own half.
        let edge = if k < 0.0 { 0 } else { axis.len() - 1 };
        return ((x - axis[edge]).abs() <= step.abs() / 2.0 + 1e-9).then_some(edge);
    }
    Some(k as usize)
}
