//! FireCast data sources: GRIDMET daily weather (NetCDF), IRWIN/WFIGS incidents (CSV, GeoJSON,
//! Esri JSON), and a seeded generator of synthetic sources in those same formats.
pub mod gridmet;
pub mod incidents;
pub mod synth;
