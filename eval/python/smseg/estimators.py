"""The forest as scikit-learn estimators. Where scikit-learn is installed they are its estimators
(BaseEstimator, ClassifierMixin: get_params / set_params / clone, score as the mean accuracy, its own
input validation and messages, check_estimator passes); without it the same methods come from the
small stand-ins below, with numpy's checks. Fitted models pickle (and go through joblib) as their
forest file's text: a pickle written by another version of smseg loads or is refused in one line."""
import inspect
import os

import numpy as np

from . import _smseg
from ._smseg import Error
from .data import as_frame_arrays

try:
    from sklearn.base import BaseEstimator as _Estimator, ClassifierMixin as _Classifier
    from sklearn.utils.multiclass import check_classification_targets
    from sklearn.utils.validation import check_is_fitted
    try:
        from sklearn.utils.validation import validate_data as _validate_data  # scikit-learn >= 1.6
    except ImportError:
        _validate_data = None
    HAVE_SKLEARN = True
except ImportError:  # the stand-ins below
    HAVE_SKLEARN = False


class _Params:
    """get_params / set_params / repr from the constructor's keyword arguments, as scikit-learn's
    BaseEstimator does; stands in for it where scikit-learn is not installed."""

    @classmethod
    def _param_names(cls):
        signature = inspect.signature(cls.__init__)
        return sorted(p.name for p in signature.parameters.values() if p.name != "self")

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


class _Accuracy:
    """score(X, y): the mean accuracy of predict(X), as scikit-learn's ClassifierMixin defines it."""

    def score(self, X, y, sample_weight=None):
        right = np.asarray(self.predict(X) == np.asarray(y), dtype=float)
        return float(np.average(right, weights=sample_weight))


if not HAVE_SKLEARN:
    _Estimator, _Classifier = _Params, _Accuracy

    def check_classification_targets(y):
        if y.dtype.kind == "f" and np.any(y != np.round(y)):
            raise Error("y: Unknown label type: continuous values (expected classes)")


def _check_fitted(estimator):
    """scikit-learn's NotFittedError (a ValueError) where it is installed, smseg.Error otherwise."""
    if HAVE_SKLEARN:
        check_is_fitted(estimator, "model_")
    elif getattr(estimator, "model_", None) is None:
        raise Error(f"{type(estimator).__name__}: not fitted: call fit (or load) first")


_NO_Y = "no_validation"  # scikit-learn's marker: only X is checked


def _table(estimator, X, y=_NO_Y, reset=True):
    """X (and y) of a tabular estimator checked as scikit-learn checks them: X 2-D, real, finite, not
    empty, float32 (the trainer's type); y one label per row; n_features_in_ set when reset, compared
    otherwise. Returns X, or (X, y) when y is given (a y of None is an error)."""
    if HAVE_SKLEARN:
        kwargs = dict(reset=reset, dtype=np.float32)
        if _validate_data is not None:
            return _validate_data(estimator, X, y, **kwargs)
        return estimator._validate_data(X, y, **kwargs)
    X = np.asarray(X, dtype=np.float32)
    if X.ndim != 2:
        raise Error(f"X: shape: expected a 2-D array (samples, features), got {X.ndim} dimensions")
    if X.shape[0] == 0 or X.shape[1] == 0:
        raise Error(f"X: shape: {X.shape}: needs at least one sample and one feature")
    if not np.all(np.isfinite(X)):
        raise Error("X: values: not all finite (NaN or infinity)")
    if reset:
        estimator.n_features_in_ = X.shape[1]
    elif X.shape[1] != estimator.n_features_in_:
        raise Error(f"X: shape: {X.shape[1]} features, but the model was fitted on {estimator.n_features_in_}")
    if isinstance(y, str) and y == _NO_Y:
        return X
    if y is None:
        raise Error(f"{type(estimator).__name__}: y: fit needs the labels (got None)")
    y = np.asarray(y)
    if y.ndim != 1 or len(y) != len(X):
        raise Error(f"y: shape: expected one label per row of X ({len(X)})")
    return X, y


def _balance_name(balance):
    """train-forest's --balance value of the estimator's balance: True / False (as before) name classes /
    none; a name goes as it is to the trainer, which refuses an unknown one naming balance."""
    if isinstance(balance, (bool, np.bool_)):
        return "classes" if balance else "none"
    if not isinstance(balance, str):
        raise Error(f"balance: expected none, sqrt, classes (or True / False), got {balance!r}")
    return balance


class ExtraTreesWindowClassifier(_Estimator):
    """train-forest as an estimator: extremely randomized trees over sampling windows on feature stacks.

    n_estimators: trees (train-forest -M); k: windows and tests per tree (-K; ks, kt override each);
    windows: "uniform" | "thesis-biased" | "learned" (with learned_from: forest files); balance:
    train-forest's --balance, "none" | "sqrt" | "classes" (True: "classes", False: "none"); criterion:
    the split score, train-forest's --score ("wehenkel-pavella" | "information-gain"); n_min, textons, features, lightness, leaf_tests: as
    train-forest's options (lightness: every frame brought to this mean fL in fit and predict alike; 0:
    off; leaf_tests: tests each tree's leaves count besides the Kt it grew on; 0: none);
    seed: same seed and inputs, same forest file as train-forest; n_jobs: threads (0: all cores; the
    forest does not depend on it). predict returns class positions (indices into classes_).
    """

    def __init__(self, n_estimators=7, k=400, windows="uniform", balance=False, seed=1, n_jobs=0, ks=None,
                 kt=None, n_min=5, criterion="wehenkel-pavella", textons=False, features=None, learned_from=None,
                 lightness=0.0, leaf_tests=0):
        self.n_estimators, self.k, self.windows, self.balance, self.seed = n_estimators, k, windows, balance, seed
        self.n_jobs, self.ks, self.kt, self.n_min, self.criterion = n_jobs, ks, kt, n_min, criterion
        self.textons, self.features, self.learned_from, self.lightness = textons, features, learned_from, lightness
        self.leaf_tests = leaf_tests

    def fit(self, stacks, frames="0:", progress=False):
        """Trains on the labelled frames inside `frames` ("A:B", half-open) of one or more work folders."""
        works = [stacks] if isinstance(stacks, (str, os.PathLike)) else list(stacks)
        self.model_ = _smseg.fit_window_forest(
            works=[os.fspath(w) for w in works], frames=frames, K=int(self.k), Ks=int(self.ks or 0),
            Kt=int(self.kt or 0), M=int(self.n_estimators), n_min=int(self.n_min), seed=int(self.seed),
            windows=self.windows, learned_from=[os.fspath(f) for f in (self.learned_from or [])],
            balance=_balance_name(self.balance), criterion=self.criterion, textons=bool(self.textons),
            features=list(self.features or []), lightness=float(self.lightness),
            leaf_tests=int(self.leaf_tests), n_jobs=int(self.n_jobs),
            progress=bool(progress))
        self._set_fitted_attributes()
        return self

    def _set_fitted_attributes(self):
        self.classes_ = np.array(self.model_.classes)
        self.features_ = list(self.model_.features)

    def _classify(self, stack):
        _check_fitted(self)
        sat, gray = as_frame_arrays(stack, self.features_)
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
        _check_fitted(self)
        self.model_.save(os.fspath(path))

    @classmethod
    def load(cls, path):
        """An estimator from a forest file (train-forest's or save's), its parameters from the file."""
        model = _smseg.WindowForest.load(os.fspath(path))
        p = model.to_json()["params"]
        est = cls(n_estimators=p["M"], k=p["K"], windows=p["windows"]["mode"], balance=p["balance"],
                  seed=p["seed"], ks=p["Ks"], kt=p["Kt"], n_min=p["n_min"], criterion=p["score"], textons=p["textons"],
                  lightness=p.get("lightness", 0.0), leaf_tests=p.get("leaf_tests", 0))
        est.model_ = model
        est._set_fitted_attributes()
        return est


class ExtraTreesClassifier(_Classifier, _Estimator):
    """Our trainer on tabular data, to compare with scikit-learn's ExtraTreesClassifier: every tree is
    grown from all rows (no bootstrap) with one random threshold per column at each node, the best
    split by criterion ("wehenkel-pavella", the thesis's normalised information gain, or
    "information-gain", scikit-learn's "entropy"); n_min: nodes with fewer rows become leaves; seed:
    same seed and data, same trees, whatever n_jobs (threads, 0: all cores).

    fit(X, y): X 2-D real (rows, columns; used as float32), y any labels (at most 254 classes).
    Fitted attributes: classes_, n_features_in_ (and feature_names_in_ for a DataFrame with scikit-
    learn), feature_importances_, model_ (the trees)."""

    def __init__(self, n_estimators=7, n_min=5, criterion="wehenkel-pavella", seed=1, n_jobs=0):
        self.n_estimators, self.n_min, self.criterion, self.seed, self.n_jobs = n_estimators, n_min, criterion, seed, n_jobs

    def fit(self, X, y):
        X, y = _table(self, X, y)
        check_classification_targets(y)
        classes, y_index = np.unique(y, return_inverse=True)
        if len(classes) > 254:
            raise Error(f"y: classes: {len(classes)} classes, at most 254")
        self.model_ = _smseg.fit_tabular(X, y_index.astype(np.uint8), len(classes), int(self.n_estimators),
                                         int(self.n_min), int(self.seed), self.criterion, int(self.n_jobs))
        self.classes_ = classes
        return self

    @property
    def feature_importances_(self):
        """Mean decrease in impurity (entropy) per column, summing to 1, as scikit-learn's forests
        define it (all zeros when no tree splits)."""
        _check_fitted(self)
        return self.model_.feature_importances

    def predict_proba(self, X):
        """(rows, classes) mean leaf distributions, rows summing to 1, columns in the order of classes_."""
        _check_fitted(self)
        return self.model_.predict_proba(_table(self, X, reset=False))

    def predict(self, X):
        """The class of largest probability per row (ties: the first in classes_)."""
        proba = self.predict_proba(X)  # first: it says "not fitted" before classes_ is read
        return self.classes_[np.argmax(proba, axis=1)]
