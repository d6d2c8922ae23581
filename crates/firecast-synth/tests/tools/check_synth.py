#!/usr/bin/env python3
"""Independent check of FireCast synthetic GRIDMET-format files with Python netCDF4 and xarray.

Usage:
    check_synth.py OUT_DIR [--dump rust_reader_dump.json]

OUT_DIR is a `firecast_synth::generate` output directory (`gridmet/<short>_<YYYY>.nc`,
`incidents/wfigs_incidents.csv`, and with `write_truth` `truth/ignition_probability_<YYYY>.nc`).
For every NetCDF file the script

* opens it with netCDF4 (libnetcdf: validates the classic header and layout) and with xarray
  (CF decoding: `_Unsigned`, `_FillValue`/`missing_value`, `scale_factor`/`add_offset`,
  `days since 1900-01-01` → dates);
* finds the data variable, orders it as [day][lat][lon] by dimension *names*;
* checks that both libraries agree, that `day` decodes to 1 January .. 31 December of the
  file's year, latitude descends from the GRIDMET grid, masked cells are the same on every day,
  and values lie in the ranges of docs/spec/data.md §2.2;
* with --dump, compares three days of every file with what the Rust reader
  (`firecast_data::gridmet::GridmetFile`) returned.

Each truth file must also be float32 in [0, 1] with the dimension order, axes and land mask of
the GRIDMET files of its year.

It also parses the incidents CSV (header, row count, date format) when present. Prints one line
per file and `ALL OK` at the end; exits 1 on any mismatch. Run with the project's Python:
    /work/main/.venv/bin/python crates/firecast-synth/tests/tools/check_synth.py OUT_DIR
"""
import csv
import glob
import json
import os
import re
import sys

import netCDF4
import numpy as np
import xarray as xr

RANGES = {
    "pr": (0, 690), "rmax": (1, 100), "rmin": (0, 100), "sph": (0, 0.02), "srad": (0, 456),
    "th": (0, 360), "tmmn": (225, 315), "tmmx": (233, 327), "vs": (0.1, 29), "bi": (0, 214),
    "erc": (0, 132), "fm100": (0.3, 33), "fm1000": (0.4, 48), "etr": (0, 27), "pet": (0, 17),
    "vpd": (0, 9.8),
    # The generator's true probability of >= 1 ignition per cell-day (truth/), not weather.
    "ignition_probability": (0, 1),
}
TRUTH = "ignition_probability"
COORDS = {"day", "lat", "lon", "crs"}
WFIGS_COLUMNS = 97

failures = []
summary = {}


def fail(msg):
    failures.append(msg)
    print("  FAIL:", msg)


def ordered(arr, dims):
    """Transpose to (day, lat, lon) by dimension names."""
    return np.transpose(arr, [dims.index(d) for d in ("day", "lat", "lon")])


def check_file(path, dump_entry):
    m = re.match(r"(\w+)_(\d{4})\.nc$", os.path.basename(path))
    short, year = m.group(1), int(m.group(2))
    lo, hi = RANGES[short]

    ds = netCDF4.Dataset(path)
    fmt = ds.file_format
    names = [n for n in ds.variables if n not in COORDS]
    if len(names) != 1:
        fail(f"{path}: data variables {names}")
        return
    name = names[0]
    v = ds.variables[name]
    dims = list(v.dimensions)
    a_nc = ordered(np.ma.filled(v[:].astype("f8"), np.nan), dims)
    days_nc = ds.variables["day"][:]
    lats = ds.variables["lat"][:]
    lons = ds.variables["lon"][:]
    has_crs = "crs" in ds.variables
    raw_dtype = v.dtype
    ds.close()

    xds = xr.open_dataset(path)
    a_xr = ordered(xds[name].values.astype("f8"), list(xds[name].dims))
    dates = xds["day"].values
    xds.close()

    # Both libraries agree (masks and values).
    if a_nc.shape != a_xr.shape:
        fail(f"{path}: shapes netCDF4 {a_nc.shape} xarray {a_xr.shape}")
        return
    if not np.array_equal(np.isnan(a_nc), np.isnan(a_xr)):
        fail(f"{path}: netCDF4 and xarray masks differ")
    diff = np.nanmax(np.abs(a_nc - a_xr)) if np.isfinite(a_nc).any() else 0.0
    if diff > 1e-6 * max(1.0, hi):
        fail(f"{path}: netCDF4 and xarray differ by {diff}")

    # Time and grid.
    n_days = 366 if (year % 4 == 0 and (year % 100 != 0 or year % 400 == 0)) else 365
    first = np.datetime64(f"{year}-01-01")
    if len(dates) != n_days or dates[0] != first or dates[-1] != np.datetime64(f"{year}-12-31"):
        fail(f"{path}: dates {dates[0]} .. {dates[-1]} ({len(dates)})")
    if not np.all(np.diff(lats) < 0):
        fail(f"{path}: latitude not descending")
    j0 = (49.4 - lats[0]) * 24
    i0 = (lons[0] + 124.7666666333) * 24
    if abs(j0 - round(j0)) > 1e-6 or abs(i0 - round(i0)) > 1e-6:
        fail(f"{path}: grid not on GRIDMET centres ({lats[0]}, {lons[0]})")

    # Mask constant over time; values in range.
    nan = np.isnan(a_nc)
    if not (nan == nan[0]).all():
        fail(f"{path}: the mask changes between days")
    valid = a_nc[~nan]
    if valid.size and (valid.min() < lo - 1e-3 * max(1, hi) or valid.max() > hi + 1e-3 * max(1, hi)):
        fail(f"{path}: values {valid.min()} .. {valid.max()} outside {lo} .. {hi}")

    # Against the Rust reader.
    compared = 0
    if dump_entry is not None:
        if int(dump_entry["first_day"]) != int(round(float(days_nc[0]))):
            fail(f"{path}: first day Rust {dump_entry['first_day']} Python {days_nc[0]}")
        if abs(dump_entry["lat0"] - lats[0]) > 1e-9 or abs(dump_entry["lon0"] - lons[0]) > 1e-9:
            fail(f"{path}: first lat/lon differ")
        for d in dump_entry["days"]:
            t = d["index"]
            rust = np.array([np.nan if x is None else x for x in d["values"]], dtype="f8")
            py = a_nc[t].reshape(-1)
            if not np.array_equal(np.isnan(rust), np.isnan(py)):
                fail(f"{path}: day {t}: Rust and Python masks differ")
                continue
            ok = ~np.isnan(py)
            # The Rust reader returns f32: allow f32 rounding of the decoded value.
            err = np.abs(rust[ok] - py[ok]) - 2e-7 * np.abs(py[ok]) - 1e-9
            if ok.any() and err.max() > 0:
                k = int(np.argmax(err))
                fail(f"{path}: day {t}: Rust {rust[ok][k]} vs Python {py[ok][k]}")
            compared += int(ok.sum())

    summary[path] = {"dims": dims, "mask": nan[0], "days": np.asarray(days_nc, dtype="f8"),
                     "lats": np.asarray(lats), "lons": np.asarray(lons), "dtype": str(raw_dtype),
                     "short": short, "year": year}
    n_valid = int((~nan[0]).sum())
    print(f"  {os.path.basename(path):16s} {fmt:16s} {name:42s} dims={'/'.join(dims):11s} "
          f"raw={str(raw_dtype):7s} crs={'y' if has_crs else 'n'} land={n_valid:4d} "
          f"min={np.nanmin(a_nc):10.4f} mean={np.nanmean(a_nc):10.4f} max={np.nanmax(a_nc):10.4f} "
          f"rust-compared={compared}")


def check_truth(path):
    """The truth file shares its year's GRIDMET layout and land mask, and is float32."""
    t = summary.get(path)
    if t is None:
        return
    if t["dtype"] != "float32":
        fail(f"{path}: stored as {t['dtype']}, expected float32")
    peers = [s for s in summary.values() if s["short"] != TRUTH and s["year"] == t["year"]]
    for g in peers:
        if g["dims"] != t["dims"]:
            fail(f"{path}: dimensions {t['dims']} but the GRIDMET files of {t['year']} have {g['dims']}")
        if not (np.array_equal(g["days"], t["days"]) and np.array_equal(g["lats"], t["lats"])
                and np.array_equal(g["lons"], t["lons"])):
            fail(f"{path}: day/lat/lon axes differ from the GRIDMET files of {t['year']}")
        if not np.array_equal(g["mask"], t["mask"]):
            fail(f"{path}: land mask differs from the GRIDMET files of {t['year']}")
        break
    print(f"  {os.path.basename(path)}: layout and mask match {len(peers)} GRIDMET file(s) of {t['year']}")


def check_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    if len(header) != WFIGS_COLUMNS or header[0] != "X" or header[-1] != "GlobalID":
        fail(f"{path}: header has {len(header)} columns")
    idx = header.index("FireDiscoveryDateTime")
    bad = [r[idx] for r in body if not re.fullmatch(r"\d{4}/\d{2}/\d{2} \d{2}:\d{2}:\d{2}\+00", r[idx])]
    if bad:
        fail(f"{path}: {len(bad)} bad dates, e.g. {bad[0]}")
    cats = {}
    for r in body:
        cats[r[header.index("IncidentTypeCategory")]] = cats.get(r[header.index("IncidentTypeCategory")], 0) + 1
    print(f"  {os.path.basename(path)}: {len(body)} records, {len(header)} columns, categories {cats}")


def main():
    args = sys.argv[1:]
    if not args:
        print(__doc__)
        sys.exit(2)
    out = args[0]
    dump = None
    if "--dump" in args:
        with open(args[args.index("--dump") + 1]) as f:
            dump = {os.path.abspath(e["path"]): e for e in json.load(f)["files"]}
    print(f"netCDF4 {netCDF4.__version__} (libnetcdf {netCDF4.__netcdf4libversion__}), "
          f"xarray {xr.__version__}, numpy {np.__version__}")
    paths = sorted(glob.glob(os.path.join(out, "gridmet", "*.nc")))
    if not paths:
        fail(f"no NetCDF files under {out}/gridmet")
    truth = sorted(glob.glob(os.path.join(out, "truth", "*.nc")))
    paths += truth
    for p in paths:
        check_file(p, None if dump is None else dump.get(os.path.abspath(p)))
    for p in truth:
        check_truth(p)
    if dump is not None:
        missing = set(dump) - {os.path.abspath(p) for p in paths}
        if missing:
            fail(f"files in the dump but not on disk: {sorted(missing)}")
    csv_path = os.path.join(out, "incidents", "wfigs_incidents.csv")
    if os.path.exists(csv_path):
        check_csv(csv_path)
    if failures:
        print(f"{len(failures)} FAILURES")
        sys.exit(1)
    print(f"ALL OK ({len(paths)} NetCDF files)")


if __name__ == "__main__":
    main()
