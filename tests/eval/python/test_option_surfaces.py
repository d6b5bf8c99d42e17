"""Every declared option reaches every surface it is declared on (issue 36: an option is said once).

The declarations are the options tables (smseg/common/options.hpp), read through
smseg.option_tables(). For each field: its flag is in the --help of the tool that takes its struct,
its config key passes `run-experiment --check`, its Python keyword is taken by the function (or is a
parameter of the estimator). Each check is also shown to fail on a name nobody declared, so that a
surface that stopped reading its table would be caught.
"""
import json

import pytest

import smseg

# The tools that take each struct whole (label-stream also takes parts of two of them).
TOOLS = {"training": "train-forest", "extract_features": "extract-features", "evaluate": "eval-forest",
         "make_sequence": "make-sequence", "label_stream": "label-stream"}
# Point parameters (the rest: a config's "synthetic" sequences).
POINT_TABLES = ["evaluate", "extract_features", "training"]
# Estimator parameters that are not training parameters: how to run, what to read.
ESTIMATOR_EXTRAS = {"n_jobs", "features", "learned_from"}


def fields_on(table, surface):
    return [f for f in smseg.option_tables()[table]["fields"] if surface in f["surfaces"]]


def test_every_table_declares_fields_with_spellings():
    tables = smseg.option_tables()
    assert set(tables) == set(TOOLS)
    for name, table in tables.items():
        keys = [f["key"] for f in table["fields"]]
        assert len(keys) == len(set(keys)), name
        for f in table["fields"]:
            assert f["help"] and f["surfaces"], (name, f["key"])
            if "command_line" in f["surfaces"]:
                assert f["flag"].startswith("-"), (name, f["key"])


@pytest.mark.parametrize("table", sorted(TOOLS))
def test_every_command_line_field_is_in_its_tools_help(table, run_tool):
    help_text = run_tool(TOOLS[table], "--help").stdout
    flags = {word for line in help_text.splitlines() for word in line.replace(",", " ").split() if word.startswith("-")}
    missing = [f["flag"] for f in fields_on(table, "command_line") if f["flag"] not in flags]
    assert not missing, f"{TOOLS[table]} --help lacks {missing}"
    assert "--no-such-option" not in flags


def check_config(run_tool, tmp_path, fixed, sweep=None, synthetic=None):
    config = {"format": "smseg-experiment", "version": 1, "name": "surfaces",
              "sequences": {"s": {"synthetic": synthetic or {"frames": 12, "width": 64, "height": 48}}},
              "fixed": {"train": "s", "train_frames": "0:6", "test_frames": "6:", **fixed}}
    if sweep:
        config["sweep"] = sweep
    path = tmp_path / "config.json"
    path.write_text(json.dumps(config))
    return run_tool("run-experiment", path, "--check")


def other_values(f):
    """Values of the field's kind besides its default, to try until one is valid."""
    d = f["default"]
    if f["type"] == "flag":
        return [not d]
    if f["type"] == "name":
        return [c.strip() for c in f["help"].rsplit(": ", 1)[1].split("|") if c.strip() not in (d, "N")]
    if d is None:
        return [300, 600] if f["type"] == "integer" else [1.5, 2.5]
    if f["type"] == "integer":
        return [d * 2, d + 1, d - 1, d // 2, d + 16, 300]
    return [d * 2, d / 2, 0.5, 1.5]


@pytest.mark.parametrize("table", POINT_TABLES)
def test_every_config_field_reaches_the_points(table, run_tool, tmp_path):
    """A sweep over the default and another value gives two points: a key whose value were dropped
    on the way would make them one point (run-experiment refuses two points of the same parameters)."""
    fields = fields_on(table, "config")
    assert fields
    for f in fields:
        default = f["default"] if f["default"] is not None else other_values(f)[-1]
        tried = []
        for other in other_values(f):
            r = check_config(run_tool, tmp_path, {}, {f["config_key"]: [default, other]})
            tried.append((other, r.stderr.strip()))
            if r.returncode == 0:
                assert r.stdout.startswith("surfaces: 2 points"), (f["config_key"], r.stdout)
                break
        else:
            pytest.fail(f"{f['config_key']}: no second value reached a point: {tried}")
    bad = check_config(run_tool, tmp_path, {"no_such_key": 1})
    assert bad.returncode != 0 and "no_such_key" in bad.stderr


def test_every_synthetic_sequence_field_is_a_key_of_synthetic_sequences(run_tool, tmp_path):
    for f in fields_on("make_sequence", "config"):
        value = f["default"] if f["default"] is not None else 1.2
        r = check_config(run_tool, tmp_path, {}, synthetic={f["config_key"]: value})
        assert r.returncode == 0, (f["config_key"], r.stderr)
    bad = check_config(run_tool, tmp_path, {}, synthetic={"no_such_key": 1})
    assert bad.returncode != 0 and "no_such_key" in bad.stderr


def test_extraction_keys_of_configs_take_a_side(run_tool, tmp_path):
    r = check_config(run_tool, tmp_path, {"test_max_keypoints": 300, "dense": True})
    assert r.returncode == 0, r.stderr
    r = check_config(run_tool, tmp_path, {"max_keypoints": 0})
    assert r.returncode != 0 and "fixed.max_keypoints" in r.stderr


def test_superpixels_in_configs_is_a_name_or_a_number(run_tool, tmp_path):
    r = check_config(run_tool, tmp_path, {}, {"superpixels": ["none", "small", 12]})
    assert r.returncode == 0 and r.stdout.startswith("surfaces: 3 points"), r.stderr
    r = check_config(run_tool, tmp_path, {"superpixels": 2})
    assert r.returncode != 0 and "fixed.superpixels" in r.stderr
    r = check_config(run_tool, tmp_path, {"superpixels": 2.5})
    assert r.returncode != 0 and "fixed.superpixels" in r.stderr


def test_every_training_field_is_a_parameter_of_the_estimator():
    params = set(smseg.ExtraTreesWindowClassifier().get_params())
    declared = {f["python_key"] for f in fields_on("training", "python")}
    assert declared <= params, f"ExtraTreesWindowClassifier lacks {declared - params}"
    assert params - declared <= ESTIMATOR_EXTRAS, f"parameters no table declares: {params - declared - ESTIMATOR_EXTRAS}"


def test_every_extraction_field_is_a_keyword_of_extract_features(tmp_path):
    for f in fields_on("extract_features", "python"):
        with pytest.raises(smseg.Error) as e:
            smseg.extract_features(tmp_path / "no-sequence", tmp_path / "work", **{f["python_key"]: f["default"]})
        assert "no-sequence" in str(e.value), (f["python_key"], str(e.value))
    with pytest.raises(smseg.Error, match="no_such_option: is not an option of extract_features"):
        smseg.extract_features(tmp_path / "no-sequence", tmp_path / "work", no_such_option=1)


def test_every_evaluation_field_is_a_keyword_of_evaluate(tmp_path):
    for f in fields_on("evaluate", "python"):
        with pytest.raises(smseg.Error) as e:
            smseg.evaluate(tmp_path / "no-forest.json", [tmp_path], **{f["python_key"]: f["default"]})
        assert "no-forest.json" in str(e.value), (f["python_key"], str(e.value))
    with pytest.raises(smseg.Error, match="no_such_option: is not an option of evaluate"):
        smseg.evaluate(tmp_path / "no-forest.json", [tmp_path], no_such_option=1)


def test_keywords_refuse_what_json_cannot_hold(tmp_path):
    with pytest.raises(smseg.Error, match="future_frames: must be a finite number"):
        smseg.extract_features(tmp_path / "no-sequence", tmp_path / "work", future_frames=float("nan"))
    with pytest.raises(smseg.Error, match="lambda_"):
        smseg.evaluate(tmp_path / "no-forest.json", [tmp_path], lambda_=float("inf"))
