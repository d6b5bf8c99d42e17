"""Bad input: a smseg.Error (a ValueError) whose message is the line the tool prints after
"<tool>: error: ", never a crash."""
import numpy as np
import pytest

import smseg


def tool_error(result, tool):
    """The one line a tool printed for an error, without its "<tool>: error: " prefix."""
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    prefix = f"{tool}: error: "
    assert lines[0].startswith(prefix)
    return lines[0][len(prefix):]


def test_missing_work_folder_same_message(run_tool, tmp_path):
    missing = tmp_path / "nowhere"
    expected = tool_error(run_tool("train-forest", missing, "-o", tmp_path / "f.json"), "train-forest")
    with pytest.raises(smseg.Error) as caught:
        smseg.ExtraTreesWindowClassifier().fit(missing)
    assert str(caught.value) == expected
    assert str(missing) in expected


def test_broken_stacks_manifest_same_message(corridor, run_tool, tmp_path):
    _, work = corridor
    broken = tmp_path / "work"
    broken.mkdir()
    text = (work / "stacks.json").read_text().replace('"smseg-stacks"', '"something-else"')
    (broken / "stacks.json").write_text(text)
    expected = tool_error(run_tool("train-forest", broken, "-o", tmp_path / "f.json"), "train-forest")
    with pytest.raises(smseg.Error) as caught:
        smseg.ExtraTreesWindowClassifier().fit(broken)
    assert str(caught.value) == expected
    with pytest.raises(smseg.Error) as caught:
        smseg.load_stack(broken, 0)
    assert str(caught.value) == expected


def test_broken_forest_file_same_message(corridor, run_tool, tmp_path):
    _, work = corridor
    (tmp_path / "forest.json").write_text('{"format": "smseg-forest", "version": 99}')
    expected = tool_error(run_tool("eval-forest", tmp_path / "forest.json", work, "-o", tmp_path / "eval"),
                          "eval-forest")
    with pytest.raises(smseg.Error) as caught:
        smseg.ExtraTreesWindowClassifier.load(tmp_path / "forest.json")
    assert str(caught.value) == expected
    with pytest.raises(smseg.Error) as caught:
        smseg.evaluate(tmp_path / "forest.json", work)
    assert str(caught.value) == expected


def test_bad_arrays_and_options_raise(corridor):
    _, work = corridor
    clf = smseg.ExtraTreesWindowClassifier(n_estimators=1, k=20)
    with pytest.raises(ValueError, match="not fitted"):  # scikit-learn's NotFittedError
        clf.predict(smseg.load_stack(work, 20))
    clf.fit(work, frames="0:9")
    with pytest.raises(smseg.Error, match="sat: expected shape"):
        clf.predict({"sat": np.zeros((2, 3, 4)), "gray": None})
    with pytest.raises(smseg.Error, match="frames: frame 999 has no feature stack"):
        smseg.load_stack(work, 999)
    with pytest.raises(smseg.Error, match="windows"):
        smseg.ExtraTreesWindowClassifier(windows="diagonal").fit(work)
    with pytest.raises(smseg.Error, match="K: must be >= 1"):
        smseg.ExtraTreesWindowClassifier(k=0).fit(work)
    with pytest.raises(smseg.Error, match="colour: is not an option of evaluate"):
        smseg.evaluate("forest.json", work, colour="red")
    # The tabular estimator's data errors are scikit-learn's own (test_sklearn.py); its options are ours.
    with pytest.raises(smseg.Error, match="criterion: "):
        smseg.ExtraTreesClassifier(criterion="gini").fit(np.zeros((5, 2)), np.arange(5) % 2)
    with pytest.raises(smseg.Error, match="n_min: must be >= 1"):
        smseg.ExtraTreesClassifier(n_min=0).fit(np.zeros((5, 2)), np.arange(5) % 2)
