//! FireCast data sources: GRIDMET daily weather (NetCDF) and IRWIN/WFIGS incidents (CSV,
//! GeoJSON, Esri JSON). The seeded generator of synthetic sources in those same formats is
//! `firecast-synth`.
pub mod gridmet;
pub mod incidents;
