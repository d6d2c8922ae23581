"""The pyretechnics side of `firecast bench behavior` and `firecast bench spread`.

Run by the bench with the peer venv's Python (.venv-peers/pyretechnics, `cargo xtask setup`):

    python pyretechnics_bench.py JOB.json

JOB names the mode (`behavior` or `spread`), the LANDFIRE layer files, the inputs (fuel
moistures and foliar moisture as fractions, the 10-m wind in km/h and the direction it comes
from), the window of cells, the repeats and an output folder. The landscape is read with
pyretechnics' own LANDFIRE loader (rasterio) and its unit conversions. Only the call being
compared is timed (time.perf_counter around it; imports, reading and cube building
excluded). Per-cell results go to OUT as raw little-endian arrays in row-major order, row 0
north (`*.f32`, `*.u8`); the last line on stdout is one JSON object with the timings.
"""

import json
import os
import sys
import time

import numpy as np

import pyretechnics
from pyretechnics.burn_cells import burn_all_cells_as_head_fire
from pyretechnics.eulerian_level_set import SpreadState, spread_fire_with_phi_field
from pyretechnics.load_landfire import load_and_convert_landfire_rasters
from pyretechnics.space_time_cube import SpaceTimeCube

NONBURNABLE = 91  # NB1: where the fuel layer has no data (the level set indexes a table by code)

WEATHER = [
    "fuel_moisture_dead_1hr",
    "fuel_moisture_dead_10hr",
    "fuel_moisture_dead_100hr",
    "fuel_moisture_live_herbaceous",
    "fuel_moisture_live_woody",
    "foliar_moisture",
]


def version():
    try:
        from importlib.metadata import version as v

        return v("pyretechnics")
    except Exception:  # pragma: no cover
        return getattr(pyretechnics, "__version__", "unknown")


def load_layers(job, flip):
    """The layers as float32 2D arrays in pyretechnics' units, cut to the job's window."""
    rasters = load_and_convert_landfire_rasters(job["layers"])
    y0, y1, x0, x1 = job["window"]
    arrays = {}
    for name, raster in rasters.items():
        a = np.asarray(raster["array"][0], dtype=np.float32)[y0:y1, x0:x1]
        nodata = raster["metadata"]["nodata"]
        if name == "fuel_model" and nodata is not None:
            a = np.where(a == np.float32(nodata), np.float32(NONBURNABLE), a)
        # The level set takes +y as north: row 0 south.
        arrays[name] = np.ascontiguousarray(np.flipud(a) if flip else a)
    return arrays


def cubes_for(job, arrays, bands):
    rows, cols = arrays["fuel_model"].shape
    shape = (bands, rows, cols)
    cubes = {name: SpaceTimeCube(shape, a) for name, a in arrays.items() if name != "elevation"}
    cubes["wind_speed_10m"] = SpaceTimeCube(shape, float(job["wind_speed_10m_kmh"]))
    cubes["upwind_direction"] = SpaceTimeCube(shape, float(job["upwind_direction_deg"]))
    for name in WEATHER:
        cubes[name] = SpaceTimeCube(shape, float(job["moisture"][name]))
    return cubes, shape


def write(out, name, array, dtype):
    np.ascontiguousarray(array, dtype=dtype).tofile(os.path.join(out, name))


def behavior(job):
    arrays = load_layers(job, flip=False)
    cubes, (_, rows, cols) = cubes_for(job, arrays, 1)
    seconds = []
    result = None
    for _ in range(job["repeats"]):
        started = time.perf_counter()
        result = burn_all_cells_as_head_fire(
            cubes, 0, use_wind_limit=job["use_wind_limit"], surface_lw_ratio_model="behave"
        )
        seconds.append(time.perf_counter() - started)
    write(job["out"], "spread_rate_m_min.f32", result["spread_rate"], "<f4")
    write(job["out"], "fire_type.u8", result["fire_type"], "u1")
    return {"rows": rows, "cols": cols, "seconds": seconds}


def spread(job):
    arrays = load_layers(job, flip=True)
    minutes = float(job["max_duration_min"])
    cubes, shape = cubes_for(job, arrays, 1)
    _, rows, cols = shape
    iy, ix = job["ignition_row_col"]
    seconds = []
    state = None
    stop = None
    for _ in range(job["repeats"]):
        state = SpreadState(shape)
        # Row-major row 0 north outside, row 0 south inside.
        state.ignite_cell((rows - 1 - iy, ix))
        started = time.perf_counter()
        out = spread_fire_with_phi_field(
            cubes,
            state,
            cube_resolution=(minutes, job["cell_size_m"], job["cell_size_m"]),
            start_time=0.0,
            max_duration=minutes,
            use_wind_limit=job["use_wind_limit"],
            surface_lw_ratio_model="behave",
            cube_refresh_rates={name: 0.0 for name in ["wind_speed_10m", "upwind_direction"] + WEATHER},
        )
        seconds.append(time.perf_counter() - started)
        state = out["spread_state"]
        stop = (out["stop_time"], out["stop_condition"])
    full = state.get_full_matrices(["time_of_arrival", "fire_type"])
    write(job["out"], "time_of_arrival_min.f32", np.flipud(full["time_of_arrival"]), "<f4")
    write(job["out"], "fire_type.u8", np.flipud(full["fire_type"]), "u1")
    return {
        "rows": rows,
        "cols": cols,
        "seconds": seconds,
        "stop_time_min": stop[0],
        "stop_condition": stop[1],
    }


def main():
    with open(sys.argv[1]) as f:
        job = json.load(f)
    report = {"behavior": behavior, "spread": spread}[job["mode"]](job)
    report["pyretechnics"] = version()
    report["python"] = sys.version.split()[0]
    report["numpy"] = np.__version__
    print(json.dumps(report), flush=True)


if __name__ == "__main__":
    main()
