"""Readers: one frame's feature stack as numpy arrays, a results file as a dict."""
import json
import os
import re

import numpy as np

from . import _smseg
from ._smseg import Error

_STACK_FILE = re.compile(r"^(\d+)(\.values\.bin|\.sat\.npy|\.gray\.npy|\.labels\.npy)?$")


def _work_and_frame(path, frame):
    """(work folder, frame) from load_stack's arguments: a work folder and a frame, or a stack file
    (WORK/stacks/000160.values.bin, a version 1 folder's 000160.sat.npy, or WORK/stacks/000160)."""
    path = os.fspath(path)
    if frame is not None:
        return path, int(frame)
    folder, name = os.path.split(os.path.normpath(path))
    match = _STACK_FILE.match(name)
    if not match or os.path.basename(folder) != "stacks":
        raise Error(f"{path}: expected a work folder and a frame, or a stack file WORK/stacks/NNNNNN.values.bin")
    return os.path.dirname(folder), int(match.group(1))


def load_stack(path, frame=None):
    """One frame's feature stack: load_stack(WORK, 160) or load_stack("WORK/stacks/000160.values.bin").

    Returns a dict: sat (F, H+1, W+1) float64 summed-area tables and gray (H, W) uint8, read-only views
    of the mapped tables (no copy); channels (F, H, W) float64, the per-pixel feature values the
    tables sum; labels (H, W) uint8 class positions (255 = void) or None for an unlabelled frame; valid
    (H, W) bool, the pixels with a class (None without labels); features, classes (names), work, frame.
    """
    work, frame = _work_and_frame(path, frame)
    stack = _smseg.load_stack(work, frame)
    sat = stack["sat"]
    stack["channels"] = sat[:, 1:, 1:] - sat[:, :-1, 1:] - sat[:, 1:, :-1] + sat[:, :-1, :-1]
    labels = stack["labels"]
    stack["valid"] = None if labels is None else labels != 255
    return stack


def load_results(path):
    """An eval-forest results file (DIR/results.json, or DIR) as a dict; Error when it is not one."""
    path = os.fspath(path)
    if os.path.isdir(path):
        path = os.path.join(path, "results.json")
    try:
        with open(path, encoding="utf-8") as f:
            results = json.load(f)
    except OSError as e:
        raise Error(f"{path}: cannot read: {e.strerror}") from None
    except json.JSONDecodeError as e:
        raise Error(f"{path}: not JSON: {e.msg} at line {e.lineno}") from None
    missing = [k for k in ("global_accuracy", "class_average_accuracy", "confusion")
               if not isinstance(results, dict) or k not in results]
    if missing:
        raise Error(f"{path}: {missing[0]}: missing (not an eval-forest results file)")
    return results


def as_frame_arrays(stack, features=None):
    """(sat, gray) of a stack given as load_stack's dict or as a (work, frame) pair.

    features: the channels wanted, by name, in this order (a forest's). A stack that names its channels
    (load_stack's "features") gives those of its tables, so a work folder with more channels than the
    forest reads (dense, context) serves it as eval-forest does; one that lacks a channel is refused by
    name. Without names, the tables are given as they are."""
    if isinstance(stack, tuple) and len(stack) == 2:
        stack = load_stack(*stack)
    if not isinstance(stack, dict) or "sat" not in stack:
        raise Error("stack: expected load_stack's dict (sat, gray, ...) or a (work, frame) pair")
    sat = np.asarray(stack["sat"])
    names = stack.get("features")
    if features is not None and names is not None and list(names) != list(features):
        missing = [f for f in features if f not in names]
        if missing:
            raise Error(f"stack: features: has no channel {missing[0]} (the forest reads {', '.join(features)})")
        sat = np.ascontiguousarray(sat[[list(names).index(f) for f in features]])
    return sat, stack.get("gray")
