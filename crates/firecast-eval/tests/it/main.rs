//! Integration tests of firecast-eval: agreement with scikit-learn 1.9.1 / SciPy / NumPy
//! (through `tests/tools/sklearn_reference.py`, run with `$FIRECAST_VENV/bin/python`;
//! the tests fail, not skip, without it), laws the metrics must obey (proptest), and
//! threshold selection.

#![allow(clippy::unwrap_used)]

mod cases;
mod laws;
mod reference;
mod sklearn;
mod threshold;
