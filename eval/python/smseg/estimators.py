"""The forest as scikit-learn-like estimators: get_params / set_params (so sklearn.base.clone works),
fit, predict, predict_proba. (No score method: `score` is the split-score parameter, as in the tools.)"""
import inspect
import os

import numpy as np

from . import _smseg
from ._smseg import Error
from .data import as_frame_arrays


class _Params:
    """get_params / set_params / repr from the constructor's keyword arguments, as scikit-learn's
    BaseEstimator does (without needing scikit-learn)."""

    @classmethod
    def _param_names(cls):
        signature = inspect.signature(cls.__init__)
        return sorted(p.name for p in signature.parameters.values() if p.name != "self")

    def _keep(self, args):
        """Stores the constructor's arguments as they are, as attributes of the same names (scikit-learn's
        convention: clone() rebuilds an estimator from get_params())."""
        for name in self._param_names():
            setattr(self, name, args[name])

    def get_params(self, deep=True):
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **params):
        names = self._param_names()
        for key, value in params.items():
            if key not in names:
                raise ValueError(f"{type(self).__name__}: {key}: not a parameter (parameters: {', '.join(names)})")
            setattr(self, key, value)
        return self

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    def _check_fitted(self):
        if getattr(self, "model_", None) is None:
            raise Error(f"{type(self).__name__}: not fitted: call fit (or load) first")


class ExtraTreesWindowClassifier(_Params):
    """train-forest as an estimator: extremely randomized trees over sampling windows on feature stacks.

    n_estimators: trees (train-forest -M); k: windows and tests per tree (-K; ks, kt override each);
    windows: "uniform" | "thesis-biased" | "learned" (with learned_from: forest files); balance: draw
    tests per class (--balance classes); n_min, score, textons, features: as train-forest's options;
    seed: same seed and inputs, same forest file as train-forest; n_jobs: threads (0: all cores; the
    forest does not depend on it). predict returns class positions (indices into classes_).
    """

    def __init__(self, n_estimators=7, k=400, windows="uniform", balance=False, seed=1, n_jobs=0, ks=None,
                 kt=None, n_min=5, score="wehenkel-pavella", textons=False, features=None, learned_from=None):
        self._keep(locals())

    def fit(self, stacks, frames="0:", progress=False):
        """Trains on the labelled frames inside `frames` ("A:B", half-open) of one or more work folders."""
        works = [stacks] if isinstance(stacks, (str, os.PathLike)) else list(stacks)
        self.model_ = _smseg.fit_window_forest(
            works=[os.fspath(w) for w in works], frames=frames, K=int(self.k), Ks=int(self.ks or 0),
            Kt=int(self.kt or 0), M=int(self.n_estimators), n_min=int(self.n_min), seed=int(self.seed),
            windows=self.windows, learned_from=[os.fspath(f) for f in (self.learned_from or [])],
            balance=bool(self.balance), score=self.score, textons=bool(self.textons),
            features=list(self.features or []), n_jobs=int(self.n_jobs), progress=bool(progress))
        self._set_fitted_attributes()
        return self

    def _set_fitted_attributes(self):
        self.classes_ = np.array(self.model_.classes)
        self.features_ = list(self.model_.features)

    def _classify(self, stack):
        self._check_fitted()
        sat, gray = as_frame_arrays(stack)
        return self.model_.classify(sat, gray if self.model_.textons else None)

    def predict(self, stack):
        """Per-pixel class positions (H, W) uint8 of one frame (load_stack's dict or (work, frame))."""
        return self._classify(stack)[0]

    def predict_proba(self, stack):
        """Per-pixel class probabilities (H, W, C) float32: the mean of the trees' leaf distributions."""
        dists = self._classify(stack)[1]
        dists /= np.float32(self.model_.n_trees)
        return dists

    def save(self, path):
        """Writes the forest file (the format train-forest writes and eval-forest reads)."""
        self._check_fitted()
        self.model_.save(os.fspath(path))

    @classmethod
    def load(cls, path):
        """An estimator from a forest file (train-forest's or save's), its parameters from the file."""
        model = _smseg.WindowForest.load(os.fspath(path))
        p = model.to_json()["params"]
        est = cls(n_estimators=p["M"], k=p["K"], windows=p["windows"]["mode"], balance=p["balance"] == "classes",
                  seed=p["seed"], ks=p["Ks"], kt=p["Kt"], n_min=p["n_min"], score=p["score"], textons=p["textons"])
        est.model_ = model
        est._set_fitted_attributes()
        return est


class ExtraTreesClassifier(_Params):
    """Our trainer on tabular data, to compare with scikit-learn's ExtraTreesClassifier: every tree is
    grown from all rows (no bootstrap) with one random threshold per column at each node, the best
    score splitting (score: "wehenkel-pavella" | "information-gain"); n_min: nodes with fewer rows
    become leaves. fit(X, y): X 2-D float (rows, columns), y any labels (at most 254 classes)."""

    def __init__(self, n_estimators=7, n_min=5, score="wehenkel-pavella", seed=1, n_jobs=0):
        self._keep(locals())

    @staticmethod
    def _check_X(X):
        X = np.asarray(X, dtype=np.float32)
        if X.ndim != 2:
            raise Error(f"X: shape: expected a 2-D array (samples, features), got {X.ndim} dimensions")
        if not np.all(np.isfinite(X)):
            raise Error("X: values: not all finite (NaN or infinity)")
        return X

    def fit(self, X, y):
        X = self._check_X(X)
        y = np.asarray(y)
        if y.ndim != 1 or len(y) != len(X):
            raise Error(f"y: shape: expected one label per row of X ({len(X)})")
        self.classes_, y_index = np.unique(y, return_inverse=True)
        if len(self.classes_) > 254:
            raise Error(f"y: classes: {len(self.classes_)} classes, at most 254")
        self.n_features_in_ = X.shape[1]
        self.model_ = _smseg.fit_tabular(X, y_index.astype(np.uint8), len(self.classes_), int(self.n_estimators),
                                         int(self.n_min), int(self.seed), self.score, int(self.n_jobs))
        return self

    def predict_proba(self, X):
        """(rows, classes) mean leaf distributions, columns in the order of classes_."""
        self._check_fitted()
        return self.model_.predict_proba(self._check_X(X))

    def predict(self, X):
        """The class of largest probability per row (ties: the first in classes_)."""
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]
