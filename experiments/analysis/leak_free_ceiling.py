"""How far above the climatology can a leak-free ignition forecaster get on synthetic data?

The generator's truth (`ignition_probability_<YYYY>.nc`, read here with xarray, independently
of FireCast's NetCDF reader) gives the true ignition probability of every cell-day. A
forecaster whose inputs end the day before cannot know the day's probability; the best it can
do is estimate it from what came before. This script scores, on an experiment's leak-free test
samples, the truth itself (the oracle, which sees the day) beside forecasts made from the truth
of earlier days (what perfect knowledge of the past would give) and the truth's own
cell-by-season average over the training years (a perfect climatology), and the experiment's
models, with paired cluster-bootstrap intervals against the climatology.

    .venv/bin/python experiments/analysis/leak_free_ceiling.py \
        experiments/runs/forecaster-choice datasets/demo/ignitions-paper build/demo/sources/truth

Prints a Markdown table (AUROC with 95 % intervals over 1000 resamples of cells, and the
difference from the climatology paired over the same resamples).
"""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import xarray as xr


def auroc(y: np.ndarray, s: np.ndarray) -> float:
    """Mann-Whitney AUROC with ties counted half."""
    r = pd.Series(s).rank(method="average").to_numpy()
    pos = y.sum()
    neg = len(y) - pos
    return float((r[y].sum() - pos * (pos + 1) / 2) / (pos * neg))


def main() -> None:
    run, dataset, truth_dir = (Path(a) for a in sys.argv[1:4])
    protocol = sys.argv[4] if len(sys.argv) > 4 else "leak_free"
    samples = pq.read_table(dataset / "samples.parquet").to_pandas().set_index("sample_id")
    pred = pd.read_csv(run / "predictions.csv")
    pred = pred[pred.protocol == protocol]
    test_ids = np.sort(pred.sample_id.unique())
    test = samples.loc[test_ids]
    y = test.label.to_numpy()
    first_test = pd.Timestamp(test.event_date.min())

    files = sorted(truth_dir.glob("ignition_probability_*.nc"))
    truth = xr.concat([xr.open_dataset(f).ignition_probability for f in files], "day").load()
    lat = xr.DataArray(test.cell_latitude.to_numpy(), dims="s")
    lon = xr.DataArray(test.cell_longitude.to_numpy(), dims="s")
    dates = pd.to_datetime(test.event_date).to_numpy()

    def truth_at(lag_days: int) -> np.ndarray:
        day = xr.DataArray(dates + np.timedelta64(lag_days, "D"), dims="s")
        return truth.sel(day=day, lat=lat, lon=lon, method="nearest").to_numpy()

    # The truth's mean by cell and day of the year over the years before the test period.
    past = truth.sel(day=truth.day < np.datetime64(first_test))
    doy = past.day.dt.dayofyear
    seasonal = past.rolling(day=31, center=True, min_periods=1).mean().groupby(doy).mean("day")
    test_doy = xr.DataArray(np.minimum(pd.DatetimeIndex(dates).dayofyear, seasonal.dayofyear.max().item()), dims="s")
    perfect_climatology = seasonal.sel(dayofyear=test_doy, lat=lat, lon=lon, method="nearest").to_numpy()

    rows = {
        "oracle: the day's true probability (sees the day)": truth_at(0),
        "the true probability of the day before": truth_at(-1),
        "mean true probability of the 7 days before": np.mean([truth_at(-k) for k in range(1, 8)], axis=0),
        "perfect climatology: the truth's mean by cell and season over the training years": perfect_climatology,
    }
    by_model = pred.groupby(["model", "sample_id"]).score.mean().unstack(0).loc[test_ids]
    for model in by_model.columns:
        rows[f"`{model}` (seed mean)"] = by_model[model].to_numpy()

    reference = by_model["climatology"].to_numpy()
    cells = test.cell_row.astype(np.int64).to_numpy() * 100_000 + test.cell_col.to_numpy()
    groups = [np.flatnonzero(cells == c) for c in np.unique(cells)]
    rng = np.random.default_rng(2025)
    draws = [np.concatenate([groups[i] for i in rng.integers(0, len(groups), len(groups))]) for _ in range(1000)]

    print(f"{len(y)} test samples ({int(y.sum())} positive), {len(groups)} cells; 95 % intervals over 1000 cell resamples\n")
    print("| forecast | AUROC | Δ vs climatology (paired) |")
    print("|---|---|---|")
    for name, s in rows.items():
        boot = np.array([auroc(y[d], s[d]) for d in draws])
        diff = np.array([auroc(y[d], s[d]) - auroc(y[d], reference[d]) for d in draws])
        point = auroc(y, s) - auroc(y, reference)
        lo, hi = np.percentile(boot, [2.5, 97.5])
        dlo, dhi = np.percentile(diff, [2.5, 97.5])
        print(f"| {name} | {auroc(y, s):.3f} [{lo:.3f}, {hi:.3f}] | {point:+.3f} [{dlo:+.3f}, {dhi:+.3f}] |")


if __name__ == "__main__":
    main()
