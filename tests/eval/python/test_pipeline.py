"""extract_features and the README's Python example."""
import os
import re
import runpy

import numpy as np
import pytest

import smseg


def test_extract_features_writes_the_tools_stacks(corridor, tmp_path):
    seq, work = corridor
    summary = smseg.extract_features(seq, tmp_path / "work", future_frames=10)  # the fixture's options
    assert summary["frames_written"] == 24 and summary["frames_skipped"] == 0
    for frame in (0, 20):
        np.testing.assert_array_equal(smseg.load_stack(tmp_path / "work", frame)["sat"], smseg.load_stack(work, frame)["sat"])
        name = f"{frame:06d}.values.bin"
        assert (tmp_path / "work" / "stacks" / name).read_bytes() == (work / "stacks" / name).read_bytes()
    again = smseg.extract_features(seq, tmp_path / "work", future_frames=10)
    assert again["frames_skipped"] == 24
    with pytest.raises(smseg.Error, match="motion"):
        smseg.extract_features(seq, tmp_path / "w2", motion="lidar")
    with pytest.raises(smseg.Error, match="speed: is not an option of extract_features"):
        smseg.extract_features(seq, tmp_path / "w2", speed=2)
    with pytest.raises(smseg.Error, match="gravity"):
        smseg.extract_features(seq, tmp_path / "w2", gravity="sideways")
    dense = smseg.extract_features(seq, tmp_path / "dense", future_frames=10, dense=True, gravity="estimate",
                                   frames="0:2")
    assert dense["frames_written"] == 2
    manifest = (tmp_path / "dense" / "stacks.json").read_text()
    assert '"fZE"' in manifest and '"dense": true' in manifest and '"estimate"' in manifest


def test_readme_python_example(corridor, source_dir, tmp_path, monkeypatch):
    _, work = corridor
    readme = (source_dir / "README.md").read_text()
    section = readme[readme.index("## Use it as a library"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    assert 'work = "out/main/work"' in code
    script = tmp_path / "example.py"
    script.write_text(code.replace('work = "out/main/work"', f"work = {str(work)!r}"))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    runpy.run_path(str(script))
    assert os.path.getsize(tmp_path / "frame.png") > 1000
