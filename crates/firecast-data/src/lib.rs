//! FireCast data readers.
pub mod gridmet;
