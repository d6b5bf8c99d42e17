"""smseg from Python: feature stacks as numpy arrays, the forest of extremely randomized trees over
sampling windows as a scikit-learn estimator, the same trainer on tabular data (a scikit-learn
classifier that passes its check_estimator), models that pickle, feature extraction and evaluation.
See the README's "Use it as a library" section.

Bad input raises smseg.Error (a ValueError) whose message is the one line the command-line tools print
after "<tool>: error: ".
"""
from ._smseg import Error, load_sequence, option_tables, read_frame, stack_manifest
from .data import load_results, load_stack
from .estimators import ExtraTreesClassifier, ExtraTreesWindowClassifier
from .pipeline import evaluate, extract_features

__version__ = "0.1.0"
__all__ = [
    "Error", "ExtraTreesClassifier", "ExtraTreesWindowClassifier", "evaluate", "extract_features",
    "load_results", "load_sequence", "load_stack", "option_tables", "read_frame", "stack_manifest",
]
