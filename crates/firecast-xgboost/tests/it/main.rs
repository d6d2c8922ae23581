//! Integration tests against the real `libxgboost.so` from the project venv, including
//! agreement with Python xgboost (`tests/tools/xgb_reference.py`).

mod common;
mod errors;
mod reference;
mod roundtrip;
