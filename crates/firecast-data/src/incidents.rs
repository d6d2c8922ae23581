//! IRWIN / WFIGS incident readers (data spec §1).
