"""Stacks, sequences and results from Python: the same numbers numpy reads from the files."""
import json

import numpy as np
import pytest

import smseg


def test_stack_round_trip(corridor):
    _, work = corridor
    frame = smseg.stack_manifest(work)["labelled_frames"][-1]
    stack = smseg.load_stack(work, frame)
    sat = stack["sat"]
    assert sat.dtype == np.float64 and stack["gray"].shape == stack["labels"].shape == (120, 160)
    np.testing.assert_array_equal(stack["valid"], stack["labels"] != 255)
    # channels are what the tables sum: summing them again gives the tables back
    channels = stack["channels"]
    assert channels.shape == (sat.shape[0], sat.shape[1] - 1, sat.shape[2] - 1)
    rebuilt = np.zeros_like(sat)
    rebuilt[:, 1:, 1:] = channels.cumsum(axis=1).cumsum(axis=2)
    np.testing.assert_allclose(rebuilt, sat, rtol=1e-9, atol=1e-6)
    assert stack["features"] == smseg.stack_manifest(work)["features"]
    # the tables are views of the mapped tables: read-only, no copy
    assert not stack["sat"].flags.writeable
    with pytest.raises(ValueError):
        stack["sat"][0, 0, 0] = 1.0
    by_file = smseg.load_stack(work / "stacks" / f"{frame:06d}.values.bin")
    np.testing.assert_array_equal(by_file["sat"], sat)


def test_unlabelled_frame_has_no_labels(corridor):
    _, work = corridor
    manifest = smseg.stack_manifest(work)
    frame = next(f for f in manifest["frames"] if f not in manifest["labelled_frames"])
    stack = smseg.load_stack(work, frame)
    assert stack["labels"] is None and stack["valid"] is None


def test_sequence_and_frames(corridor):
    seq, _ = corridor
    s = smseg.load_sequence(seq)
    assert (s["width"], s["height"], s["frame_count"]) == (160, 120, 24)
    assert s["labelled_frames"] == [0, 4, 8, 12, 16, 20]
    assert "floor" in s["classes"]
    f = smseg.read_frame(seq, 4)
    assert f["left"].shape == (120, 160, 3) and f["left"].dtype == np.uint8
    assert f["labels"].shape == (120, 160)
    assert set(np.unique(f["labels"])) <= set(range(len(s["classes"]))) | {255}


def test_results_reader(tmp_path):
    (tmp_path / "results.json").write_text(json.dumps({"global_accuracy": 0.5, "class_average_accuracy": 0.4,
                                                       "confusion": {}}))
    assert smseg.load_results(tmp_path)["global_accuracy"] == 0.5
    (tmp_path / "results.json").write_text("{}")
    with pytest.raises(smseg.Error, match="global_accuracy: missing"):
        smseg.load_results(tmp_path)
