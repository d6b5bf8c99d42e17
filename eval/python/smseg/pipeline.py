"""Feature extraction and evaluation, with the tools' options as keyword arguments."""
import os
import tempfile

from . import _smseg


def extract_features(sequence_dir, out_dir, **options):
    """extract-features SEQUENCE -o OUT as a call: writes the work folder OUT (stacks.json, stacks/,
    tracks.json, path.png; not cloud.pcd) and returns its summary as a dict.

    Options: every option of extract-features, '-' as '_' (motion, stereo, keypoints, tracker,
    max_keypoints, camera_height, focal, future_frames, appearance, dense, gravity, force, ...; the whole
    list with defaults in smseg.option_tables()["extract_features"]; "--seed" is sfm_seed), and frames
    ("A:B"), progress (on a terminal only), n_jobs (0: all cores), verbose (the solver's summaries).
    """
    return _smseg.extract_features(os.fspath(sequence_dir), os.fspath(out_dir), dict(options))


def evaluate(forest, works, **options):
    """eval-forest FOREST WORK... as a call: returns the results dict (what results.json holds).

    forest: a forest file, or a fitted ExtraTreesWindowClassifier. works: a work folder or a list.
    Options: every option of eval-forest, '-' as '_' (grid, superpixels, votes, vote, trees, tolerance,
    seed, smooth, lambda_ for --lambda, connectivity, smooth_cycles, smooth_window, smooth_bands,
    smooth_contrast; smseg.option_tables()["evaluate"]), and test_frames ("110:"), progress, n_jobs;
    out (a folder: also writes out/results.json) and pictures (also out/frames/*.png).
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
