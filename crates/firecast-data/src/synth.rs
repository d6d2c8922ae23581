//! Synthetic WFIGS + GRIDMET sources (seeded test bed).
