#!/usr/bin/env python3
"""scikit-learn / xgboost references of FireCast's flattened baselines, for
`firecast bench forecast`.

Usage: baselines_reference.py DIR

DIR holds what FireCast exported for one protocol of an experiment:

    x_train.npy, x_val.npy, x_test.npy   '<f4', rows x (days * variables): the flattened
                                 windows, day-major, every variable of the dataset
    y_train.npy, y_test.npy      '|u1', 0/1
    x_{train,val,test}_<inputs>.npy   (optional, one set per network) the exact
                                 inputs FireCast's MLP trained on (its per-variable scaling,
                                 month features if any)
    config.json                  {"seed": 0, "threads": N,
                                  "models": [{"name": str, "kind": str,
                                              "params": {FireCast's resolved hyper-parameters},
                                              "columns": [int, ...] | null,
                                              "standardize": bool,
                                              "inputs": "flat" | <name of a file pair>}]}

Each model is built with the same hyper-parameters (FireCast's names mapped to the Python
classes' keywords), fitted on the training rows and scored on the test rows. `columns`
selects the model's variables; `standardize` puts a StandardScaler fitted on the training
rows in front (as FireCast does for logistic regression and KNN). Logistic regression is fitted
on float64 copies of the same values: scikit-learn's lbfgs on float32 data stops ~1e-3 short
of the optimum (see firecast-baselines). Accuracy is `predict` (threshold 0.5), AUROC
`roc_auc_score` on `predict_proba`; `proba_val` (the validation rows' scores) lets FireCast
pick Table III's threshold on each side. Fit times cover `fit` only.

Prints one JSON object:

    {"versions": {"python", "numpy", "sklearn", "xgboost"},
     "models": {name: {"class", "accuracy", "roc_auc", "fit_seconds", "n_iter",
                       "n_parameters", "proba": [...], "proba_val": [...]}}}

with the scores as repr() strings, so they parse back bit for bit.
"""

import json
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import sklearn
import xgboost as xgb
from sklearn.ensemble import GradientBoostingClassifier, RandomForestClassifier
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import accuracy_score, roc_auc_score
from sklearn.naive_bayes import GaussianNB
from sklearn.neighbors import KNeighborsClassifier
from sklearn.neural_network import MLPClassifier
from sklearn.preprocessing import StandardScaler
from sklearn.tree import DecisionTreeClassifier

# Both sides stop at the same max_iter; the warning says what the output already shows.
warnings.filterwarnings("ignore", category=ConvergenceWarning)


def tree_keywords(p):
    return {
        "criterion": p.get("criterion", "gini"),
        "max_depth": p.get("max_depth"),
        "min_samples_split": p.get("min_samples_split", 2),
        "min_samples_leaf": p.get("min_samples_leaf", 1),
        "max_features": p.get("max_features"),
    }


def build(kind, p, seed, threads):
    """The Python estimator for one FireCast model and its resolved parameters."""
    if kind == "logistic_regression":
        return LogisticRegression(C=p["c"], max_iter=p["max_iter"], tol=p["tol"],
                                  fit_intercept=p["fit_intercept"])
    if kind == "gaussian_nb":
        return GaussianNB(var_smoothing=p["var_smoothing"])
    if kind == "decision_tree":
        return DecisionTreeClassifier(random_state=seed, **tree_keywords(p))
    if kind == "random_forest":
        return RandomForestClassifier(n_estimators=p["n_estimators"], bootstrap=p["bootstrap"],
                                      random_state=seed, n_jobs=threads, **tree_keywords(p))
    if kind == "gradient_boosting":
        kw = tree_keywords(p)
        kw.pop("criterion")
        return GradientBoostingClassifier(n_estimators=p["n_estimators"],
                                          learning_rate=p["learning_rate"],
                                          subsample=p["subsample"], random_state=seed, **kw)
    if kind == "knn":
        return KNeighborsClassifier(n_neighbors=p["n_neighbors"], weights=p["weights"],
                                    algorithm="brute", metric="euclidean", n_jobs=threads)
    if kind == "xgboost":
        return xgb.XGBClassifier(
            n_estimators=p["n_estimators"], max_depth=p["max_depth"],
            learning_rate=p["learning_rate"], subsample=p["subsample"],
            colsample_bytree=p["colsample_bytree"], min_child_weight=p["min_child_weight"],
            reg_lambda=p["reg_lambda"], reg_alpha=p["reg_alpha"], gamma=p["gamma"],
            tree_method=p["tree_method"], max_bin=p["max_bin"], objective=p["objective"],
            n_jobs=p["nthread"], random_state=seed)
    if kind == "mlp":
        # FireCast's `mlp` is scikit-learn's MLPClassifier restated in tch: one ReLU layer,
        # Adam, L2 alpha/2·‖W‖²/batch, the training-loss stopping rule.
        return MLPClassifier(hidden_layer_sizes=(p["hidden"],), activation="relu", solver="adam",
                             alpha=p["weight_decay"], batch_size=p["batch_size"],
                             learning_rate_init=p["lr"], max_iter=p["max_epochs"], tol=p["tol"],
                             n_iter_no_change=p["patience"], shuffle=True, random_state=seed)
    raise SystemExit(f"unknown model kind {kind!r}")


def parameters(model):
    coefs = getattr(model, "coefs_", None)
    if coefs is None:
        return None
    return int(sum(c.size for c in coefs) + sum(b.size for b in model.intercepts_))


def main():
    d = Path(sys.argv[1])
    cfg = json.loads((d / "config.json").read_text())
    x_train = np.load(d / "x_train.npy")
    x_test = np.load(d / "x_test.npy")
    x_val = np.load(d / "x_val.npy")
    y_train = np.load(d / "y_train.npy").astype(np.int64)
    y_test = np.load(d / "y_test.npy").astype(np.int64)
    assert x_train.dtype == np.float32 and x_test.dtype == np.float32
    seed = int(cfg.get("seed", 0))
    threads = int(cfg.get("threads", 1))
    out = {
        "versions": {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "sklearn": sklearn.__version__,
            "xgboost": xgb.__version__,
        },
        "models": {},
    }
    for m in cfg["models"]:
        kind, p = m["kind"], m["params"]
        inputs = m.get("inputs", "flat")
        if inputs != "flat":
            xtr, xte, xva = (np.load(d / f"x_{part}_{inputs}.npy") for part in ("train", "test", "val"))
        else:
            cols = m.get("columns")
            xtr, xte, xva = (x_train, x_test, x_val) if cols is None else (
                x_train[:, cols], x_test[:, cols], x_val[:, cols])
        if m.get("standardize"):
            scaler = StandardScaler().fit(xtr)
            xtr, xte, xva = scaler.transform(xtr), scaler.transform(xte), scaler.transform(xva)
        if kind == "logistic_regression":
            xtr, xte, xva = xtr.astype(np.float64), xte.astype(np.float64), xva.astype(np.float64)
        model = build(kind, p, seed, threads)
        t0 = time.perf_counter()
        model.fit(xtr, y_train)
        elapsed = time.perf_counter() - t0
        proba = model.predict_proba(xte)[:, 1].astype(np.float64)
        proba_val = (model.predict_proba(xva)[:, 1].astype(np.float64) if len(xva)
                     else np.zeros(0))
        n_iter = getattr(model, "n_iter_", None)
        # The public path (sklearn.ensemble.RandomForestClassifier, xgboost.XGBClassifier).
        public = [p for p in type(model).__module__.split(".") if not p.startswith("_")]
        if public[0] == "xgboost":
            public = ["xgboost"]
        out["models"][m["name"]] = {
            "class": ".".join(public + [type(model).__name__]),
            "accuracy": float(accuracy_score(y_test, model.predict(xte))),
            "roc_auc": float(roc_auc_score(y_test, proba)),
            "fit_seconds": elapsed,
            "n_iter": None if n_iter is None else int(np.max(n_iter)),
            "n_parameters": parameters(model),
            # repr() strings parse back exactly (JSON numbers may lose the last bit).
            "proba": [repr(float(v)) for v in proba],
            "proba_val": [repr(float(v)) for v in proba_val],
        }
        print(f"{m['name']}: {elapsed:.2f} s", file=sys.stderr, flush=True)
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
