"""Reference predictions from Python xgboost for firecast-xgboost's agreement test.

Usage: xgb_reference.py DIR

DIR holds x_train.npy (<f4, rows x cols), y_train.npy (<f4, 0/1), x_test.npy and
configs.json: a list of objects
    {"name": str,
     "params": {xgboost native name: string value, ...},   # exactly what Rust passed to
                                                           # XGBoosterSetParam
     "num_boost_round": int,
     "sklearn": {XGBClassifier keyword: value, ...},
     "model": "file name of the model Rust saved with save_json (optional)",
     "margin": {"train": "m_train.npy", "test": "m_test.npy"},  # optional base_margin
     "iteration_end": int}                                      # optional, trees used

Prints one JSON object on stdout:
    {"xgboost_version": "3.2.0",
     "results": {name: {"train": [bits...],        # xgboost.train(params, DMatrix)
                        "classifier": [bits...],   # XGBClassifier(**sklearn).predict_proba[:, 1]
                        "rust_model": [bits...]}}} # the Rust-saved model loaded in Python
Probabilities are the float32 values XGBoost returned, as their IEEE-754 bit patterns
(uint32), so the comparison is exact and no decimal round trip is involved.
"""

import json
import os
import sys

import numpy as np
import xgboost as xgb


def bits(values: np.ndarray) -> list:
    """float32 predictions as their uint32 bit patterns."""
    return np.ascontiguousarray(values, dtype=np.float32).view(np.uint32).tolist()


def main() -> None:
    root = sys.argv[1]
    x_train = np.load(os.path.join(root, "x_train.npy"))
    y_train = np.load(os.path.join(root, "y_train.npy"))
    x_test = np.load(os.path.join(root, "x_test.npy"))
    with open(os.path.join(root, "configs.json"), encoding="utf-8") as f:
        configs = json.load(f)

    results = {}
    for config in configs:
        out = {}
        m_train = m_test = None
        if config.get("margin"):
            m_train = np.load(os.path.join(root, config["margin"]["train"]))
            m_test = np.load(os.path.join(root, config["margin"]["test"]))
        rounds = (0, config.get("iteration_end", 0))
        dtrain = xgb.DMatrix(x_train, label=y_train, missing=np.nan, base_margin=m_train)
        booster = xgb.train(
            dict(config["params"]), dtrain, num_boost_round=config["num_boost_round"]
        )
        dtest = xgb.DMatrix(x_test, missing=np.nan, base_margin=m_test)
        out["train"] = bits(booster.predict(dtest, iteration_range=rounds))

        clf = xgb.XGBClassifier(**config["sklearn"])
        clf.fit(x_train, y_train.astype(np.int64), base_margin=m_train)
        out["classifier"] = bits(
            clf.predict_proba(x_test, base_margin=m_test, iteration_range=rounds)[:, 1]
        )

        if config.get("model"):
            loaded = xgb.Booster(model_file=os.path.join(root, config["model"]))
            out["rust_model"] = bits(loaded.predict(dtest, iteration_range=rounds))
        results[config["name"]] = out

    print(json.dumps({"xgboost_version": xgb.__version__, "results": results}))


if __name__ == "__main__":
    main()
