#!/usr/bin/env python3
"""scikit-learn's trees, node by node, for firecast-baselines' exact-tree test.

Usage: sklearn_trees.py DIR

DIR holds x_train.npy, x_test.npy ('<f4', rows x features), y_train.npy ('|u1', 0/1) and
config.json:

    {"random_states": [0, 12345],
     "models": {"<name>": {"model": "decision_tree" | "random_forest" | "gradient_boosting",
                           <hyper-parameters as in the Rust spec>}}}

Every model is fitted once per random_state on the training rows (float32, as FireCast's
trees see them). Prints one JSON object; floats are repr() strings so they parse exactly:

    {"sklearn_version": ...,
     "fits": {"<name>/<random_state>": {
         "proba": [...],                 # P(class 1) on the test rows
         "trees": [{"feature": [...], "threshold": [...], "value": [...]}, ...]}}}

`feature` is tree_.feature (-2 at leaves), `threshold` tree_.threshold, and `value` the
class-1 fraction (classifier trees) or tree_.value[:, 0, 0] (boosting's regression trees).
"""

import json
import sys
from pathlib import Path

import numpy as np
import sklearn
from sklearn.ensemble import GradientBoostingClassifier, RandomForestClassifier
from sklearn.tree import DecisionTreeClassifier


def build(params, seed):
    p = dict(params)
    kind = p.pop("model")
    if kind == "decision_tree":
        return DecisionTreeClassifier(random_state=seed, **p)
    if kind == "random_forest":
        return RandomForestClassifier(random_state=seed, n_jobs=1, **p)
    if kind == "gradient_boosting":
        return GradientBoostingClassifier(random_state=seed, **p)
    raise SystemExit(f"unsupported model kind {kind!r}")


def dump(tree, column):
    t = tree.tree_
    return {
        "feature": [int(v) for v in t.feature],
        "threshold": [repr(float(v)) for v in t.threshold],
        "value": [repr(float(v)) for v in t.value[:, 0, column]],
    }


def main():
    d = Path(sys.argv[1])
    cfg = json.loads((d / "config.json").read_text())
    x_train = np.load(d / "x_train.npy")
    x_test = np.load(d / "x_test.npy")
    y_train = np.load(d / "y_train.npy").astype(np.int64)
    assert x_train.dtype == np.float32 and x_test.dtype == np.float32
    out = {"sklearn_version": sklearn.__version__, "fits": {}}
    for name, params in cfg["models"].items():
        for seed in cfg["random_states"]:
            model = build(params, seed).fit(x_train, y_train)
            entry = {"proba": [repr(float(v)) for v in model.predict_proba(x_test)[:, 1]]}
            if isinstance(model, DecisionTreeClassifier):
                entry["trees"] = [dump(model, 1)]
            elif isinstance(model, RandomForestClassifier):
                entry["trees"] = [dump(t, 1) for t in model.estimators_]
            else:
                entry["trees"] = [dump(t, 0) for t in model.estimators_[:, 0]]
            out["fits"][f"{name}/{seed}"] = entry
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
