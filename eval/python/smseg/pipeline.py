"""Feature extraction and evaluation, with the tools' options as keyword arguments."""
import os
import tempfile

from . import _smseg


def extract_features(sequence_dir, out_dir, **options):
    """extract-features SEQUENCE -o OUT as a call: writes the work folder OUT (stacks.json, stacks/,
    tracks.json, path.png; not cloud.pcd) and returns its summary as a dict.

    Options (extract-features's, '-' as '_'): motion ("auto" | "stereo" | "sfm"), stereo, keypoints,
    tracker, max_keypoints, camera_height, focal, frames ("A:B"), future_frames, appearance (bool), dense
    (bool: stereo matching, or a plane sweep on SfM runs), gravity ("level" | "estimate", stereo), force,
    progress (on a terminal only), n_jobs (0: all cores), verbose (the solver's summaries on stderr).
    """
    return _smseg.extract_features(os.fspath(sequence_dir), os.fspath(out_dir), dict(options))


def evaluate(forest, works, **options):
    """eval-forest FOREST WORK... as a call: returns the results dict (what results.json holds).

    forest: a forest file, or a fitted ExtraTreesWindowClassifier. works: a work folder or a list.
    Options (eval-forest's): test_frames ("110:"), grid, superpixels ("small" | "large" | N), votes,
    vote ("sum" | "majority"), trees, tolerance, seed, smooth ("none" | "graphcut"), lambda_, progress,
    n_jobs; out (a folder: also writes out/results.json) and pictures (also out/frames/*.png).
    """
    if isinstance(works, (str, os.PathLike)):
        works = [works]
    works = [os.fspath(w) for w in works]
    if hasattr(forest, "save"):  # a fitted estimator: evaluated from its forest file, as the tool would
        with tempfile.TemporaryDirectory(prefix="smseg-") as tmp:
            path = os.path.join(tmp, "forest.json")
            forest.save(path)
            return _smseg.evaluate(path, works, dict(options))
    return _smseg.evaluate(os.fspath(forest), works, dict(options))
