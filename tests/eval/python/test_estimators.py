"""The estimators against the tools: the same forest file as train-forest, the same scores as
eval-forest, scikit-learn's clone and get_params, and the trainer on tabular data."""
import json

import numpy as np
import pytest
from sklearn.base import clone

import smseg
from conftest import without_timings

TRAIN = dict(n_estimators=3, k=60, seed=7)


def test_fit_writes_train_forests_file(corridor, run_tool, tmp_path):
    _, work = corridor
    tool = run_tool("train-forest", work, "--train-frames", "0:13", "-K", 60, "-M", 3, "--seed", 7,
                    "--balance", "classes", "-o", tmp_path / "tool.json")
    assert tool.returncode == 0, tool.stderr
    clf = smseg.ExtraTreesWindowClassifier(balance=True, **TRAIN).fit(work, frames="0:13")
    clf.save(tmp_path / "python.json")
    assert without_timings((tmp_path / "python.json").read_text()) == \
        without_timings((tmp_path / "tool.json").read_text())
    # another seed gives another forest: the comparison can fail
    other = smseg.ExtraTreesWindowClassifier(balance=True, **{**TRAIN, "seed": 8}).fit(work, frames="0:13")
    other.save(tmp_path / "other.json")
    assert without_timings((tmp_path / "other.json").read_text()) != \
        without_timings((tmp_path / "tool.json").read_text())


def test_sqrt_balance_and_leaf_tests_as_train_forest(corridor, run_tool, tmp_path):
    _, work = corridor
    tool = run_tool("train-forest", work, "--train-frames", "0:13", "-K", 60, "-M", 3, "--seed", 7,
                    "--balance", "sqrt", "--leaf-tests", 500, "-o", tmp_path / "tool.json")
    assert tool.returncode == 0, tool.stderr
    clf = smseg.ExtraTreesWindowClassifier(balance="sqrt", leaf_tests=500, **TRAIN).fit(work, frames="0:13")
    clf.save(tmp_path / "python.json")
    assert without_timings((tmp_path / "python.json").read_text()) == \
        without_timings((tmp_path / "tool.json").read_text())
    loaded = smseg.ExtraTreesWindowClassifier.load(tmp_path / "tool.json").get_params()
    assert loaded["balance"] == "sqrt" and loaded["leaf_tests"] == 500  # as trained, not "unbalanced"
    without = smseg.ExtraTreesWindowClassifier(balance="sqrt", **TRAIN).fit(work, frames="0:13")
    assert without.model_.to_json()["trees"] != clf.model_.to_json()["trees"]  # the leaves counted more
    with pytest.raises(smseg.Error, match="balance"):
        smseg.ExtraTreesWindowClassifier(balance="half", **TRAIN).fit(work, frames="0:13")


def test_predict_reads_the_forests_channels_by_name(corridor):
    _, work = corridor
    stack = smseg.load_stack(work, 20)
    wanted = [stack["features"][i] for i in (3, 0)]  # a subset, out of order
    clf = smseg.ExtraTreesWindowClassifier(features=wanted, **TRAIN).fit(work, frames="0:13")
    assert list(clf.features_) == wanted
    by_name = clf.predict(stack)  # every channel of the work folder: the forest's picked by name
    picked = {"sat": np.ascontiguousarray(stack["sat"][[3, 0]]), "gray": stack["gray"]}
    np.testing.assert_array_equal(by_name, clf.predict(picked))
    lacking = dict(stack, sat=stack["sat"][1:], features=stack["features"][1:])
    with pytest.raises(smseg.Error, match=f"no channel {wanted[1]}"):
        clf.predict(lacking)


def test_predict_scores_as_eval_forest(corridor, run_tool, tmp_path):
    _, work = corridor
    clf = smseg.ExtraTreesWindowClassifier(**TRAIN).fit(work, frames="0:13")
    clf.save(tmp_path / "forest.json")
    tool = run_tool("eval-forest", tmp_path / "forest.json", work, "--test-frames", "13:", "--no-pictures", "-q",
                    "-o", tmp_path / "eval")
    assert tool.returncode == 0, tool.stderr
    expected = json.loads((tmp_path / "eval" / "results.json").read_text())
    right = labelled = 0
    for frame in (16, 20):
        stack = smseg.load_stack(work, frame)
        labels = clf.predict(stack)
        proba = clf.predict_proba(stack)
        assert labels.shape == stack["labels"].shape and proba.shape == labels.shape + (len(clf.classes_),)
        np.testing.assert_allclose(proba.sum(axis=2), 1.0, rtol=1e-5)
        np.testing.assert_array_equal(np.argmax(proba, axis=2), labels)
        right += int(np.sum((labels == stack["labels"])[stack["valid"]]))
        labelled += int(np.sum(stack["valid"]))
    assert right / labelled == pytest.approx(expected["global_accuracy"], abs=1e-12)
    results = smseg.evaluate(tmp_path / "forest.json", work, test_frames="13:")
    assert results["confusion"] == expected["confusion"]
    assert smseg.evaluate(clf, [work], test_frames="13:")["global_accuracy"] == expected["global_accuracy"]


def test_save_load_round_trip(corridor, tmp_path):
    _, work = corridor
    clf = smseg.ExtraTreesWindowClassifier(**TRAIN).fit(work, frames="0:13")
    clf.save(tmp_path / "forest.json")
    loaded = smseg.ExtraTreesWindowClassifier.load(tmp_path / "forest.json")
    assert loaded.get_params()["n_estimators"] == 3 and loaded.get_params()["seed"] == 7
    stack = smseg.load_stack(work, 20)
    np.testing.assert_array_equal(loaded.predict(stack), clf.predict(stack))
    np.testing.assert_array_equal(loaded.predict((str(work), 20)), clf.predict(stack))


def test_sklearn_clone_and_params():
    clf = smseg.ExtraTreesWindowClassifier(n_estimators=5, k=100, windows="thesis-biased", seed=3)
    params = clf.get_params()
    assert params["n_estimators"] == 5 and params["windows"] == "thesis-biased" and params["balance"] is False
    twin = clone(clf)
    assert twin is not clf and twin.get_params() == params and not hasattr(twin, "model_")
    assert clf.set_params(seed=9) is clf and clf.seed == 9
    with pytest.raises(ValueError, match="trees"):
        clf.set_params(trees=3)
    tab = smseg.ExtraTreesClassifier(n_estimators=4, n_min=2, criterion="information-gain", seed=5)
    assert clone(tab).get_params() == tab.get_params() == \
        {"n_estimators": 4, "n_min": 2, "criterion": "information-gain", "seed": 5, "n_jobs": 0}


def test_tabular_classifier_learns_and_is_deterministic():
    from sklearn.datasets import make_classification
    X, y = make_classification(n_samples=600, n_features=8, n_informative=5, n_classes=3, random_state=0)
    labels = np.array(["a", "b", "c"])[y]
    clf = smseg.ExtraTreesClassifier(n_estimators=20, seed=1).fit(X[:400], labels[:400])
    assert list(clf.classes_) == ["a", "b", "c"]
    proba = clf.predict_proba(X[400:])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    assert np.mean(clf.predict(X[400:]) == labels[400:]) > 0.7  # chance is 1/3
    one_thread = smseg.ExtraTreesClassifier(n_estimators=20, seed=1, n_jobs=1).fit(X[:400], labels[:400])
    np.testing.assert_array_equal(one_thread.predict_proba(X[400:]), proba)
    other = smseg.ExtraTreesClassifier(n_estimators=20, seed=2).fit(X[:400], labels[:400])
    assert not np.array_equal(other.predict_proba(X[400:]), proba)


def test_tabular_matches_forest_peers(run_tool, tmp_path):
    rng = np.random.default_rng(3)
    X = rng.normal(size=(300, 4)).astype(np.float32)
    y = (X[:, 0] + 0.5 * X[:, 1] > 0).astype(int) + (X[:, 2] > 1)
    for name, rows in (("train", slice(0, 200)), ("held", slice(200, 300))):
        lines = ["label," + ",".join(f"c{i}" for i in range(4))]
        lines += [f"{label}," + ",".join(repr(float(v)) for v in row) for label, row in zip(y[rows], X[rows])]
        (tmp_path / f"{name}.csv").write_text("\n".join(lines) + "\n")
    tool = run_tool("forest-peers", tmp_path / "train.csv", tmp_path / "held.csv", "-M", 9, "--seed", 4,
                    "--classes", 3, "-o", tmp_path / "peers.json")
    assert tool.returncode == 0, tool.stderr
    expected = json.loads((tmp_path / "peers.json").read_text())["runs"][0]["accuracy"]
    clf = smseg.ExtraTreesClassifier(n_estimators=9, seed=4).fit(X[:200], y[:200])
    assert np.mean(clf.predict(X[200:]) == y[200:]) == pytest.approx(expected, abs=1e-12)
