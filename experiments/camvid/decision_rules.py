#!/usr/bin/env python3
"""How far a decision rule alone can move global accuracy against class average, on a cross-validation.

Usage: decision_rules.py OUT CONFIG RUN [--pixels N] [--seed S]

OUT and CONFIG: a finished cross-validate.sh run (its forests and evaluations are read, nothing is
trained). For each fold, RUN's forest labels every labelled frame it was evaluated on (the works in
OUT/folds/HELD/RUN/eval-fold-p*/results.json) with the Python module, and up to N of those pixels
(default 2 000 000 a fold, drawn with seed S) keep their posteriors. Not smoothed: the rules act on the
forest's posteriors, before any graph cut. Three families of labellings, each as fold means (%):

- prior power P (eval-forest --prior-power): argmax p_c / prior_c^P;
- the Bayes-optimal mix of the two objectives: alpha global + (1 - alpha) class average is maximised
  in expectation by argmax p_c (alpha + (1 - alpha) / (C true_prior_c)), where p is the posterior under
  the true prior; with the forest's training prior (its leaves' tests), p_c / prior_c * (alpha
  true_prior_c + (1 - alpha) / C), the true prior taken as the forest's undone by its balance
  (sqrt: prior^2; classes: the training pixels' shares are not in the file, so refused; none: itself);
- per-class weights fitted on the held-out pixels themselves (coordinate ascent on class average +
  global over log-weights on top of P = 0.25): an upper bound no rule chosen without those labels can
  beat.

Writes OUT/decision-rules-RUN.json and prints the table. Needs the built module on PYTHONPATH.
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cross_validate  # noqa: E402  (the config's reader and the forests' names)
import smseg  # noqa: E402

POWERS = [0, 0.125, 0.25, 0.375, 0.5, 0.75, 1]
ALPHAS = [1, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2, 0.1, 0]


def forest_prior(forest_json):
    """forest::class_prior: each class's share of the tests in the leaves."""
    counts = np.zeros(len(forest_json["classes"]))
    for tree in forest_json["trees"]:
        for node in tree["nodes"]:
            if "counts" in node:
                counts += np.asarray(node["counts"], float)
    return counts / counts.sum()


def fold_pixels(out, held, run, clf, pixels, rng):
    """(posteriors float32 [n, C], labels uint8 [n]) of up to `pixels` labelled pixels of the held-out run."""
    evals = sorted(e for e in os.listdir(os.path.join(out, "folds", held, run)) if e.startswith("eval-fold-p"))
    if not evals:
        cross_validate.fail(f"{out}/folds/{held}/{run}: no eval-fold-p* (run cross-validate.sh first)")
    with open(os.path.join(out, "folds", held, run, evals[0], "results.json")) as f:
        works = json.load(f)["params"]["works"]
    q, y = [], []
    for work in works:
        for frame in smseg.stack_manifest(work)["labelled_frames"]:
            stack = smseg.load_stack(work, frame)
            valid = stack["valid"]
            q.append(clf.predict_proba(stack)[valid])
            y.append(stack["labels"][valid])
    q, y = np.concatenate(q), np.concatenate(y)
    keep = rng.choice(len(y), size=min(pixels, len(y)), replace=False)
    return q[keep], y[keep]


def scores(q, y, weights):
    """(global, class average) of argmax q_c w_c over classes present in y."""
    C = q.shape[1]
    labels = np.argmax(q * weights.astype(np.float32)[None, :], axis=1)
    cm = np.bincount(y.astype(np.int64) * C + labels, minlength=C * C).reshape(C, C)
    n = cm.sum(axis=1)
    return cm.trace() / cm.sum(), float(np.mean(np.diag(cm)[n > 0] / n[n > 0]))


def fold_means(folds, weights_of):
    g, a = zip(*(scores(q, y, weights_of(prior)) for q, y, prior in folds))
    return 100 * float(np.mean(g)), 100 * float(np.mean(a))


def fitted_weights(folds, base_power=0.25, steps=(-0.6, -0.3, 0.3, 0.6), sweeps=3):
    C = folds[0][0].shape[1]
    base = lambda prior, lw: np.exp(lw) * (prior.min() / prior) ** base_power
    objective = lambda lw: sum(fold_means(folds, lambda prior: base(prior, lw)))
    lw, best = np.zeros(C), objective(np.zeros(C))
    for _ in range(sweeps):
        for c in range(C):
            for d in steps:
                trial = lw.copy()
                trial[c] += d
                value = objective(trial)
                if value > best:
                    lw, best = trial, value
    return lw, fold_means(folds, lambda prior: base(prior, lw))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("config")
    ap.add_argument("run")
    ap.add_argument("--pixels", type=int, default=2_000_000)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    config = cross_validate.load_config(a.config)
    spec = config["runs"].get(a.run) or cross_validate.fail(f"{a.config}: runs: no run {a.run}")
    if "context" in spec or "textons" in spec:
        cross_validate.fail(f"{a.config}: runs.{a.run}: auto-context and texton-channel runs are not read here")
    key = cross_validate.digest(spec["train"], spec.get("forest", config["forest"]))
    rng = np.random.default_rng(a.seed)
    folds, balance = [], None
    for held in sorted(os.listdir(os.path.join(a.out, "folds"))):
        forest_path = os.path.join(a.out, "folds", held, "forests", key + ".json")
        if not os.path.isdir(os.path.join(a.out, "folds", held, a.run)):
            continue
        if not os.path.isfile(forest_path):
            cross_validate.fail(f"{forest_path}: missing (run cross-validate.sh with {a.config} first)")
        clf = smseg.ExtraTreesWindowClassifier.load(forest_path)
        forest = clf.model_.to_json()
        balance = forest["params"]["balance"]
        q, y = fold_pixels(a.out, held, a.run, clf, a.pixels, rng)
        folds.append((q, y, forest_prior(forest)))
        print(f"{held}: {len(y)} pixels", flush=True)
    if not folds:
        cross_validate.fail(f"{a.out}/folds: no fold evaluated {a.run}")
    if balance == "classes":
        cross_validate.fail(f"{a.run}: --balance classes: the true class shares are not in the forest file")
    undo = (lambda p: p ** 2) if balance == "sqrt" else (lambda p: p)

    def mix(prior, alpha):
        true = undo(prior) / undo(prior).sum()
        return (alpha * true + (1 - alpha) / len(prior)) / prior

    result = {"run": a.run, "pixels_per_fold": a.pixels, "folds": len(folds),
              "power": {str(p): fold_means(folds, lambda prior: (prior.min() / prior) ** p) for p in POWERS},
              "mix": {str(al): fold_means(folds, lambda prior: mix(prior, al)) for al in ALPHAS}}
    log_weights, fitted = fitted_weights(folds)
    result["fitted_on_held_out"] = {"log_weights": log_weights.tolist(), "global_class_average": fitted}
    print("rule | parameter | global | class avg")
    for family in ("power", "mix"):
        for k, (g, c) in result[family].items():
            print(f"{family} | {k} | {g:.1f} | {c:.1f}")
    print(f"per-class weights fitted on the held-out pixels | | {fitted[0]:.1f} | {fitted[1]:.1f}")
    cross_validate.write_atomic(os.path.join(a.out, f"decision-rules-{a.run}.json"), json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
