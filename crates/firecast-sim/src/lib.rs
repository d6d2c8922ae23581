//! firecast-sim: the fire simulator's spread-rate kernels.
//!
//! - [`rothermel`]: Rothermel (1972) / Albini (1976) surface spread exactly as the USFS
//!   `behave` engine implements it, over the standard fuel models of [`fuel`].
//! - [`concord`]: the Concord / FireCastRL single-particle compatibility kernel, quirks
//!   included, with a corrected variant.
//! - [`spread_csv`]: the CSV front end of `firecast sim spread-rate`.

pub mod concord;
pub mod fuel;
pub mod rothermel;
pub mod spread_csv;

pub use concord::{
    ConcordCell, ConcordFuel, ConcordFuelConstants, ConcordSpread, ConcordWind, DroughtLevel, EdgeCasePolicy,
    LandCover, MoistureTable, SpreadVariant,
};
pub use fuel::{FuelModel, UnknownFuelModel};
pub use rothermel::{
    FuelBedIntermediates, FuelMoisture, RothermelError, SpreadInputs, SurfaceFireBehavior, SurfaceFuelBed,
    WindLimit,
};
pub use spread_csv::{SpreadCsvError, spread_rate_csv};
