"""Shared settings of the firecast package's tests (run by `cargo xtask test` through
crates/firecast-py/tests/python.rs, or by hand: `.venv/bin/python -m pytest crates/firecast-py/tests/python`)."""

from __future__ import annotations

import json
import os

import pytest

# A small grid keeps every test fast; with a 10 mi/h west wind the fire keeps burning.
SMALL_LANDSCAPE = {"procedural": {"seed": 3, "width": 48, "height": 32}}
WIND_CONFIG = {"max_steps": 200, "sim": {"wind": {"speed_mph": 10.0, "from_direction_deg": 270.0}}}


# Two-hour steps and a 50 % daily low-intensity latch: from step 12 (day 1) the episode seed
# changes what burns, so seeding mistakes show.
RANDOM_SIM = {"dt_min": 120.0, "wind": WIND_CONFIG["sim"]["wind"], "latch_daily_probability": [0.5] * 4}


def small(**config):
    """Constructor keywords for a small windy environment; `config` overrides keys."""
    return {"landscape": SMALL_LANDSCAPE, "config": {**WIND_CONFIG, **config}}


@pytest.fixture(scope="session")
def rust_streams():
    """Episodes played by the Rust environments directly (written by tests/python.rs)."""
    path = os.environ.get("FIRECAST_PY_FIXTURE")
    if not path:
        pytest.skip("FIRECAST_PY_FIXTURE is unset: run through `cargo test -p firecast-py` to get the Rust streams")
    with open(path, encoding="utf-8") as f:
        return json.load(f)
