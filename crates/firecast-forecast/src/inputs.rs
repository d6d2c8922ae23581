//! The interface every model of the comparison is fitted and scored through: the inputs it
//! sees, the training context and the progress callback. Apart from [`crate::models`], the
//! dispatcher, so that the models it dispatches to ([`crate::neural`],
//! [`crate::minirocket`]) take it from below.

use crate::data::{Block, SampleMeta};

/// What a model sees: the protocol's days of every dataset variable, plus sample facts.
pub struct Inputs<'a> {
    pub block: &'a Block,
    pub meta: Vec<&'a SampleMeta>,
}

/// Progress of a long fit: (done, total, what).
pub type Progress<'a> = &'a (dyn Fn(u64, u64, &str) + Sync);

/// Training context: the training side, the validation side (early stopping, plateau
/// schedules) and the run's seed and device.
pub struct FitContext<'a> {
    pub train: Inputs<'a>,
    pub train_labels: &'a [bool],
    pub val: Inputs<'a>,
    pub val_labels: &'a [bool],
    pub seed: u64,
    pub device: tch::Device,
    pub progress: Progress<'a>,
    /// Per-epoch curves (neural models) are reported here: (epoch, key, value).
    pub curve: &'a (dyn Fn(i64, &str, f64) + Sync),
}
