#!/usr/bin/env python3
"""Reference GRIDMET window extraction, the way the FireCastRL authors' builder does it.

Kept in the repository as the honest baseline for `firecast bench gridmet`: per sample and
per variable, the yearly file is opened with xarray (opened files are cached, as the
authors' prefetch cache does), the nearest cell is chosen by an independent argmin on the
lat and lon axes (docs/spec/data.md §4.6), and the window's days are sliced out of each year it
touches, then concatenated. CF decoding is xarray's default (mask and scale).

Usage: gridmet_xarray.py GRIDMET_DIR SAMPLES_CSV OUT_F32 VAR[,VAR...] FIRST_OFFSET LAST_OFFSET
SAMPLES_CSV has columns sample_id,lat,lon,date (YYYY-MM-DD, the GRIDMET day of the sample).
OUT_F32 receives float32 little-endian values [sample][day][variable] (NaN = missing).
Prints one JSON line: {"seconds": <extraction time, excluding interpreter start>, ...}.
"""
import csv
import datetime as dt
import json
import os
import sys
import time

import numpy as np
import xarray as xr


def main():
    gridmet_dir, samples_csv, out_path, variables, first, last = sys.argv[1:7]
    variables = variables.split(",")
    first, last = int(first), int(last)
    with open(samples_csv, newline="") as f:
        samples = [(float(r["lat"]), float(r["lon"]), dt.date.fromisoformat(r["date"])) for r in csv.DictReader(f)]
    n_days = last - first + 1
    out = np.full((len(samples), n_days, len(variables)), np.nan, dtype="<f4")
    cache = {}

    def data_array(var, year):
        key = (var, year)
        if key not in cache:
            ds = xr.open_dataset(os.path.join(gridmet_dir, f"{var}_{year}.nc"))
            name = next(n for n, v in ds.data_vars.items() if v.ndim == 3)
            cache[key] = ds[name]
        return cache[key]

    start_clock = time.perf_counter()
    for s, (lat, lon, date) in enumerate(samples):
        start = date + dt.timedelta(days=first)
        end = date + dt.timedelta(days=last)
        for v, var in enumerate(variables):
            pieces = []
            for year in range(start.year, end.year + 1):
                da = data_array(var, year)
                lat_i = int(np.abs(da["lat"].values - lat).argmin())
                lon_i = int(np.abs(da["lon"].values - lon).argmin())
                lo = max(start, dt.date(year, 1, 1))
                hi = min(end, dt.date(year, 12, 31))
                cell = da.isel(lat=lat_i, lon=lon_i)
                piece = cell.sel(day=slice(np.datetime64(lo), np.datetime64(hi))).values
                pieces.append(piece)
            series = np.concatenate(pieces).astype("<f4")
            if var == "pr":
                series = np.where(series < 0, 0, series)  # as pyMETRIC and FireCast clamp
            out[s, : len(series), v] = series[:n_days]
    seconds = time.perf_counter() - start_clock
    out.tofile(out_path)
    print(json.dumps({"seconds": seconds, "samples": len(samples), "variables": len(variables),
                      "files_opened": len(cache), "xarray": xr.__version__}))


if __name__ == "__main__":
    main()
