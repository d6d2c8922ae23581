#!/usr/bin/env python3
"""scikit-learn reference for firecast-baselines' fidelity test.

Usage: sklearn_baselines.py DIR

DIR holds x_train.npy, x_test.npy ('<f4', rows x features), y_train.npy, y_test.npy
('|u1', 0/1) and config.json:

    {"seed": 0,
     "standardize": ["logistic_regression", "knn"],
     "float64": ["<name>", ...],         # optional: fit these on float64 copies
     "spread_seeds": [1, 2],             # optional: refit seeded models with these seeds
     "models": {"<name>": {"model": "<kind>", <hyper-parameters as in the Rust spec>}}}

Every model is fitted on the training rows (StandardScaler-transformed for the names in
"standardize", as float32 like the Rust side) and scored on the test rows. Names in
"float64" get float64 copies of the same values (scikit-learn's lbfgs on float32 data
stalls at float32 precision, ~1e-3 away from the optimum in probability). The scaled
matrices are written back as x_train_std.npy / x_test_std.npy so the caller can compare
its own scaler bit for bit. Prints one JSON object:

    {"sklearn_version": ..., "scaler": {"mean": [repr...], "scale": [repr...]},
     "models": {"<name>": {"proba": [...], "accuracy": a, "roc_auc": r,
                           "fit_seconds": t, "n_iter": k | null,
                           "spread": [{"seed": s, "accuracy": a, "roc_auc": r}, ...]}}}
"""

import json
import sys
import time
from pathlib import Path

import numpy as np
import sklearn
from sklearn.ensemble import GradientBoostingClassifier, RandomForestClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import accuracy_score, roc_auc_score
from sklearn.naive_bayes import GaussianNB
from sklearn.neighbors import KNeighborsClassifier
from sklearn.preprocessing import StandardScaler
from sklearn.tree import DecisionTreeClassifier


def build(params, seed):
    """The sklearn estimator for one Rust spec (keys are sklearn's, except c -> C)."""
    p = dict(params)
    kind = p.pop("model")
    if kind == "logistic_regression":
        p["C"] = p.pop("c")
        return LogisticRegression(**p)
    if kind == "gaussian_nb":
        return GaussianNB(**p)
    if kind == "decision_tree":
        return DecisionTreeClassifier(random_state=seed, **p)
    if kind == "random_forest":
        return RandomForestClassifier(random_state=seed, n_jobs=2, **p)
    if kind == "gradient_boosting":
        return GradientBoostingClassifier(random_state=seed, **p)
    if kind == "knn":
        return KNeighborsClassifier(algorithm="brute", metric="euclidean", **p)
    raise SystemExit(f"unknown model kind {kind!r}")


def main():
    d = Path(sys.argv[1])
    cfg = json.loads((d / "config.json").read_text())
    x_train = np.load(d / "x_train.npy")
    x_test = np.load(d / "x_test.npy")
    y_train = np.load(d / "y_train.npy").astype(np.int64)
    y_test = np.load(d / "y_test.npy").astype(np.int64)
    assert x_train.dtype == np.float32 and x_test.dtype == np.float32

    scaler = StandardScaler().fit(x_train)
    xs_train = scaler.transform(x_train)
    xs_test = scaler.transform(x_test)
    assert xs_train.dtype == np.float32
    np.save(d / "x_train_std.npy", xs_train)
    np.save(d / "x_test_std.npy", xs_test)

    seed = cfg.get("seed", 0)
    standardize = set(cfg.get("standardize", []))
    float64 = set(cfg.get("float64", []))
    out = {
        "sklearn_version": sklearn.__version__,
        "scaler": {
            "mean": [repr(float(v)) for v in scaler.mean_],
            "scale": [repr(float(v)) for v in scaler.scale_],
        },
        "models": {},
    }
    for name, params in cfg["models"].items():
        xtr, xte = (xs_train, xs_test) if name in standardize else (x_train, x_test)
        if name in float64:
            xtr, xte = xtr.astype(np.float64), xte.astype(np.float64)
        model = build(params, seed)
        t0 = time.perf_counter()
        model.fit(xtr, y_train)
        elapsed = time.perf_counter() - t0
        proba = model.predict_proba(xte)[:, 1].astype(np.float64)
        n_iter = getattr(model, "n_iter_", None)
        entry = {
            "proba": proba.tolist(),
            "accuracy": float(accuracy_score(y_test, model.predict(xte))),
            "roc_auc": float(roc_auc_score(y_test, proba)),
            "fit_seconds": elapsed,
            "n_iter": None if n_iter is None else int(np.max(n_iter)),
            "spread": [],
        }
        if params["model"] in ("decision_tree", "random_forest", "gradient_boosting"):
            for s in cfg.get("spread_seeds", []):
                m = build(params, s).fit(xtr, y_train)
                p = m.predict_proba(xte)[:, 1]
                entry["spread"].append(
                    {
                        "seed": s,
                        "accuracy": float(accuracy_score(y_test, m.predict(xte))),
                        "roc_auc": float(roc_auc_score(y_test, p)),
                    }
                )
        out["models"][name] = entry
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
