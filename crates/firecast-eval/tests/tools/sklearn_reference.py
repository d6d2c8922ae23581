"""Reference values for firecast-eval's integration test (tests/it).

Usage: python sklearn_reference.py CASES.json  (or "-" to read stdin)

Reads {"cases": [{"name", "y": [0/1...], "p": [...], "threshold", "probabilities",
"p_b", "threshold_b", "delong"}], "erfc": [x...], "chi2_1df": [x...],
"binomtest": [[k, n]...], "trim_mean": [[values]...], "quantile": [{"values", "q"}]}
and prints JSON with what scikit-learn, SciPy and NumPy compute for them. Every float
is written as its IEEE-754 bit pattern (an unsigned 64-bit integer), so no value is
changed by decimal printing and parsing and NaN and infinities need no special form.
A call that raises gives {"error": message} in place of its value.

DeLong is checked against an independent O(n^2) construction of the structural
components (DeLong, DeLong & Clarke-Pearson 1988) written here with NumPy only.
"""

import json
import math
import struct
import sys
import warnings

import numpy as np
import scipy
import scipy.special
import scipy.stats
import sklearn
from sklearn.calibration import calibration_curve
from sklearn.metrics import (
    accuracy_score,
    average_precision_score,
    balanced_accuracy_score,
    brier_score_loss,
    confusion_matrix,
    f1_score,
    log_loss,
    matthews_corrcoef,
    precision_recall_curve,
    precision_score,
    recall_score,
    roc_auc_score,
    roc_curve,
)

warnings.simplefilter("ignore")


def enc(x):
    """A float as its IEEE-754 bits."""
    return struct.unpack("<Q", struct.pack("<d", float(x)))[0]


def enc_list(a):
    return [enc(v) for v in np.asarray(a, dtype=float).ravel()]


def guarded(f):
    try:
        return f()
    except Exception as e:  # the Rust side decides whether an error was expected
        return {"error": f"{type(e).__name__}: {e}"}


def threshold_metrics(y, p, t):
    pred = (p > t).astype(int)
    tn, fp, fn, tp = confusion_matrix(y, pred, labels=[0, 1]).ravel()
    return {
        "tn": int(tn),
        "fp": int(fp),
        "fn": int(fn),
        "tp": int(tp),
        "accuracy": enc(accuracy_score(y, pred)),
        "precision": enc(precision_score(y, pred, zero_division=0)),
        "recall": enc(recall_score(y, pred, zero_division=0)),
        "f1": enc(f1_score(y, pred, zero_division=0)),
        "balanced_accuracy": enc(balanced_accuracy_score(y, pred)),
        "mcc": enc(matthews_corrcoef(y, pred)),
    }


def calibration(y, p, n_bins, strategy):
    prob_true, prob_pred = calibration_curve(y, p, n_bins=n_bins, strategy=strategy)
    # Counts per non-empty bin, binned as calibration_curve bins (for ECE).
    if strategy == "quantile":
        edges = np.percentile(p, np.linspace(0, 1, n_bins + 1) * 100)
    else:
        edges = np.linspace(0.0, 1.0, n_bins + 1)
    ids = np.searchsorted(edges[1:-1], p)
    total = np.bincount(ids, minlength=n_bins)
    counts = total[total != 0]
    out = {
        "n_bins": n_bins,
        "strategy": strategy,
        "prob_true": enc_list(prob_true),
        "prob_pred": enc_list(prob_pred),
        "counts": [int(c) for c in counts],
    }
    if strategy == "uniform":
        # Guo et al.: sum over bins of |B|/n * |acc(B) - conf(B)|.
        out["ece"] = enc(np.sum(counts / len(p) * np.abs(prob_true - prob_pred)))
    return out


def delong_quadratic(y, pa, pb):
    """DeLong's test from the O(m*n) kernel psi(X, Y) = 1[X > Y] + 1/2 1[X = Y]."""
    pos, neg = y == 1, y == 0
    m, n = int(pos.sum()), int(neg.sum())
    out = {}
    v10, v01 = [], []
    for s in (pa, pb):
        x, yy = s[pos][:, None], s[neg][None, :]
        psi = (x > yy).astype(float) + 0.5 * (x == yy)
        v10.append(psi.mean(axis=1))  # one per positive
        v01.append(psi.mean(axis=0))  # one per negative
        out.setdefault("aucs", []).append(float(psi.mean()))
    s10 = np.cov(np.vstack(v10))
    s01 = np.cov(np.vstack(v01))
    cov = s10 / m + s01 / n
    var = cov[0, 0] + cov[1, 1] - 2 * cov[0, 1]
    diff = out["aucs"][0] - out["aucs"][1]
    se = math.sqrt(max(var, 0.0))
    res = {"auc_a": enc(out["aucs"][0]), "auc_b": enc(out["aucs"][1]), "se": enc(se)}
    if se > 0:
        z = diff / se
        res["z"] = enc(z)
        res["p_value"] = enc(math.erfc(abs(z) / math.sqrt(2)))
    return res


def mcnemar(y, pred_a, pred_b):
    ok_a, ok_b = pred_a == y, pred_b == y
    b = int(np.sum(ok_a & ~ok_b))
    c = int(np.sum(~ok_a & ok_b))
    if b + c < 25:
        k = min(b, c)
        p = scipy.stats.binomtest(k, b + c, 0.5).pvalue if b + c > 0 else 1.0
        return {"b": b, "c": c, "exact": True, "statistic": enc(k), "p_value": enc(p)}
    stat = (abs(b - c) - 1) ** 2 / (b + c)
    return {"b": b, "c": c, "exact": False, "statistic": enc(stat), "p_value": enc(scipy.stats.chi2.sf(stat, 1))}


def run_case(case):
    y = np.asarray(case["y"], dtype=int)
    p = np.asarray(case["p"], dtype=float)
    t = float(case["threshold"])
    out = {"name": case["name"]}
    out["roc_auc"] = guarded(lambda: enc(roc_auc_score(y, p)))
    out["average_precision"] = guarded(lambda: enc(average_precision_score(y, p)))

    def roc():
        fpr, tpr, thr = roc_curve(y, p)
        return {"fpr": enc_list(fpr), "tpr": enc_list(tpr), "thresholds": enc_list(thr)}

    def pr():
        precision, recall, thr = precision_recall_curve(y, p)
        return {"precision": enc_list(precision), "recall": enc_list(recall), "thresholds": enc_list(thr)}

    out["roc_curve"] = guarded(roc)
    out["pr_curve"] = guarded(pr)
    out["at_threshold"] = guarded(lambda: threshold_metrics(y, p, t))
    if case["probabilities"]:
        out["brier"] = guarded(lambda: enc(brier_score_loss(y, p)))
        out["log_loss"] = guarded(lambda: enc(log_loss(y, p, labels=[0, 1])))
        out["calibration"] = [
            guarded(lambda nb=nb, st=st: calibration(y, p, nb, st))
            for st in ("uniform", "quantile")
            for nb in (3, 5, 10)
        ]
    if "p_b" in case:
        pb = np.asarray(case["p_b"], dtype=float)
        pred_a = (p > t).astype(int)
        pred_b = (pb > float(case["threshold_b"])).astype(int)
        out["mcnemar"] = mcnemar(y, pred_a, pred_b)
        if case.get("delong") and min(int(y.sum()), int((1 - y).sum())) >= 2:
            out["delong"] = delong_quadratic(y, p, pb)
    return out


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "-"
    src = sys.stdin if path == "-" else open(path, encoding="utf-8")
    spec = json.load(src)
    result = {
        "versions": {"sklearn": sklearn.__version__, "scipy": scipy.__version__, "numpy": np.__version__},
        "cases": [run_case(c) for c in spec.get("cases", [])],
        "erfc": [enc(scipy.special.erfc(x)) for x in spec.get("erfc", [])],
        "chi2_1df": [enc(scipy.stats.chi2.sf(x, 1)) for x in spec.get("chi2_1df", [])],
        "binomtest": [enc(scipy.stats.binomtest(k, n, 0.5).pvalue) for k, n in spec.get("binomtest", [])],
        "trim_mean": [enc(scipy.stats.trim_mean(np.asarray(v, dtype=float), 0.25)) for v in spec.get("trim_mean", [])],
        "quantile": [enc_list(np.quantile(np.asarray(q["values"], dtype=float), q["q"])) for q in spec.get("quantile", [])],
    }
    json.dump(result, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
