#!/usr/bin/env python3
"""Leave-one-run-out cross-validation on CamVid's six labelled runs (docs/camvid.md, "Choosing by
cross-validation").

usage: cross_validate.py CAMVID_DIR OUT CONFIG [--reuse BENCHMARK_OUT] [--runs NAME,...] [--jobs N]

Each run of CAMVID_DIR's train and val splits (on ../shared/data/camvid: the five 1 Hz train runs and
the 15 Hz val run) is held out in turn: the forests of CONFIG's runs are trained on the others and
tested on it. The held-out run is tested at the rate of the test split (1 Hz): a 1 Hz run as it is; a
faster run cut into interleaved 1 Hz phases (subsample.py; val: 15), each extracted as its own
sequence, scored together. The faster run whole is reported beside ("whole"), not in the fold means. Training runs are extracted with --require-label (the training filters), held-out runs
without (no label reaches a test feature), each with CONFIG's extract options (default benchmark.sh's:
--appearance --dense, with the plane-sweep baseline of runs filmed faster than 2 Hz).

CONFIG (JSON):
  {"extract": ["--appearance", "--dense"],                              extract-features options (default
                                                                        shown; without --dense, no plane
                                                                        sweep: a cheap protocol for levers
                                                                        of forests that read no dense channel)
   "forest": ["-K", "400", "--Kt", "20000", "-M", "7", "--seed", "1"],   train-forest options of every run
   "prior_power": [0, 0.5, 1],                                         eval-forest --prior-power points
   "runs": {"NAME": {"train": [train-forest options],
                     "context": [second forest's options],             optional: auto-context (4 folds)
                     "textons": [learn-textons options],               optional: texton channels fTx0..
                                                                        (a dictionary learned per fold on
                                                                        its training folders, add-textons
                                                                        on every folder it reads)
                     "hog_classes": [learn-hog-classes options],       optional: HOG class channels fHg<class>
                                                                        (a model learned per fold on its
                                                                        training folders, add-hog-classes
                                                                        on every folder it reads)
                     "people": [add-people options],                   optional: people-detector channels
                                                                        fHogD, fHogI (add-people on every
                                                                        folder, once for all folds)
                     "eval": [eval-forest options],
                     "forest": [...]}, ...}}                           optional: this run's own forest options

OUT: sequences/, work/{train,test}/, people/ (add-people's folders), folds/HELD/ (forests/, context/ and textons/ under a digest of their
options, shared by the runs that share them; NAME/eval-{fold,whole}-p<power>/results.json),
cross-validation.json (every fold's figures, and per run and power the mean and sample standard
deviation over the folds of global, class-average and mean IoU, and per-class means), and
cross-validation.md (the table) and cross-validation.png (global against class average over the prior
powers, the curve of the trade-off, fold means with spreads). Everything resumes: a finished extraction, forest or evaluation is kept.
--reuse takes extractions from a benchmark.sh OUT (its work/train and work/test folders) by symlink.
Tools from $SMSEG_BIN (default build/bin).
"""
import argparse
import hashlib
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

from sweep_options import median_step, sweep_options

HERE = os.path.dirname(os.path.abspath(__file__))
CONTEXT_FOLDS = 4
BENCHMARK_EXTRACT = ["--appearance", "--dense"]  # benchmark.sh's extraction (with its plane-sweep choice)
TEST_RATE_HZ = 1.0  # the test split's frame rate: faster runs are tested at it (interleaved phases)


def fail(message):
    sys.exit(f"cross-validate: {message}")


def run(command, log=None):
    """Runs a tool; on failure prints its output and stops with one line naming it."""
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if log:
        with open(log, "w") as f:
            f.write(result.stdout)
    if result.returncode != 0:
        sys.stderr.write(result.stdout[-4000:])
        fail(f"{os.path.basename(command[0])} failed (exit {result.returncode}): {' '.join(command)}")
    return result.stdout


def write_atomic(path, text):
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=os.path.dirname(os.path.abspath(path)))
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.chmod(tmp, 0o644)  # mkstemp's 0600 is for the temporary name only
    os.replace(tmp, path)


def load_config(path):
    try:
        with open(path) as f:
            config = json.load(f)
    except (OSError, ValueError) as e:
        fail(f"{path}: {e}")
    if not isinstance(config.get("runs"), dict) or not config["runs"]:
        fail(f"{path}: runs: expected an object naming at least one run")
    for key in config:
        if key not in ("extract", "forest", "prior_power", "runs"):
            fail(f"{path}: {key}: unknown key (expected extract, forest, prior_power, runs)")
    strings = lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v)
    for key, tool in (("extract", "extract-features"), ("forest", "train-forest")):
        if key in config and not strings(config[key]):
            fail(f"{path}: {key}: expected a list of {tool} options (strings)")
    for name, r in config["runs"].items():
        if not isinstance(r, dict) or "train" not in r:
            fail(f"{path}: runs.{name}.train: expected a list of train-forest options")
        for key, value in r.items():
            if key not in ("train", "context", "eval", "forest", "textons", "hog_classes", "people"):
                fail(f"{path}: runs.{name}.{key}: unknown key (expected train, context, eval, forest, textons, "
                     "hog_classes, people)")
            if not strings(value):
                fail(f"{path}: runs.{name}.{key}: expected a list of options (strings)")
    powers = config.setdefault("prior_power", [0])
    if not powers or not all(isinstance(p, (int, float)) and 0 <= p <= 4 for p in powers):
        fail(f"{path}: prior_power: expected a list of numbers in 0..4")
    config.setdefault("forest", ["-K", "400", "--Kt", "20000", "-M", "7", "--seed", "1"])
    config.setdefault("extract", BENCHMARK_EXTRACT)
    return config


# ---- preparation: sequences and work folders ------------------------------------------------------

def phases_of(sequence):
    """How many interleaved phases bring a run to the test split's rate (1: it is at that rate already)."""
    step = median_step(sequence)
    return max(1, round(1.0 / (TEST_RATE_HZ * step))) if step else 1


def prepare_sequences(bin_dir, camvid, out):
    runs_dir = os.path.join(out, "sequences", "runs")
    if not os.path.isdir(runs_dir):
        tmp = runs_dir + ".partial"
        shutil.rmtree(tmp, ignore_errors=True)
        run([f"{bin_dir}/import-camvid", camvid, "--split", "train,val", "-o", tmp])
        os.replace(tmp, runs_dir)
    names = sorted(n for n in os.listdir(runs_dir) if os.path.isfile(os.path.join(runs_dir, n, "sequence.json")))
    if len(names) < 2:
        fail(f"{runs_dir}: {len(names)} run(s): leaving one out needs at least two")
    runs = {n: os.path.join(runs_dir, n) for n in names}
    phases = {}
    for name, sequence in runs.items():
        count = phases_of(sequence)
        if count == 1:
            continue
        phases_dir = os.path.join(out, "sequences", f"{name}-1hz")
        if not os.path.isdir(phases_dir):
            tmp = phases_dir + ".partial"
            shutil.rmtree(tmp, ignore_errors=True)
            os.makedirs(tmp)
            run([sys.executable, os.path.join(HERE, "subsample.py"), sequence, str(count), os.path.join(tmp, f"{name}-1hz")])
            os.replace(tmp, phases_dir)
        phases[name] = sorted(os.path.join(phases_dir, n) for n in os.listdir(phases_dir))
    return runs, phases


def extraction(bin_dir, out, reuse, extract, side, sequence):
    """One work folder: reused from a benchmark's OUT by symlink, kept when finished, else extracted.
    `extract`: the config's extract-features options (the plane-sweep choice added with --dense)."""
    name = os.path.basename(sequence)
    work = os.path.join(out, "work", side, name)
    # extract-features writes stacks.json first, so that a killed run resumes: only this marker, written
    # once it has finished, says the folder is whole. Without it extract-features runs again (and keeps
    # the frames on disk).
    finished = os.path.join(out, "work", side, f".finished-{name}")
    if os.path.isfile(finished) and os.path.isfile(os.path.join(work, "stacks.json")):
        return work
    os.makedirs(os.path.dirname(work), exist_ok=True)
    if reuse and os.path.isfile(os.path.join(reuse, "work", side, name, "stacks.json")):
        if os.path.islink(work):
            os.unlink(work)
        os.symlink(os.path.abspath(os.path.join(reuse, "work", side, name)), work)
        return work
    options = extract + ["--threads", "1", "-q"] + (sweep_options(sequence) if "--dense" in extract else [])
    if side == "train":
        options.append("--require-label")
    os.makedirs(os.path.join(out, "logs"), exist_ok=True)
    run([f"{bin_dir}/extract-features", sequence, "-o", work] + options,
        log=os.path.join(out, "logs", f"extract-{side}-{name}.txt"))
    write_atomic(finished, "")
    return work


def keep_extract_options(out, extract):
    """OUT/work/extract.json: the extract-features options of OUT's work folders, which another config
    with other options must not resume from."""
    path = os.path.join(out, "work", "extract.json")
    if os.path.isfile(path):
        with open(path) as f:
            kept = json.load(f)
        if kept != extract:
            fail(f"{path}: {out}'s work folders were extracted with {kept}, the config asks for {extract}: use another OUT")
        return
    os.makedirs(os.path.dirname(path), exist_ok=True)
    write_atomic(path, json.dumps(extract) + "\n")


def prepare_works(bin_dir, out, reuse, extract, runs, phases, jobs):
    jobs_list = [("train", s) for s in runs.values()] + [("test", s) for s in runs.values()]
    jobs_list += [("test", p) for name in phases for p in phases[name]]
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        works = list(pool.map(lambda j: extraction(bin_dir, out, reuse, extract, *j), jobs_list))
    n = len(runs)
    train = dict(zip(runs, works[:n]))
    test = dict(zip(runs, works[n:2 * n]))
    rest = iter(works[2 * n:])
    phase_works = {name: [next(rest) for _ in phases[name]] for name in phases}
    return train, test, phase_works


# ---- folds -----------------------------------------------------------------------------------------

def digest(*parts):
    return hashlib.sha1(json.dumps(parts).encode()).hexdigest()[:12]


def train_run(bin_dir, config, spec, train_works, fold):
    """The run's first forest and the forest it is tested with (with "context", a second forest over the
    first one's posteriors). Forests live in FOLD/forests/ under a digest of their options, so runs that
    share a forest (the same forest evaluated two ways) train it once."""
    forests = os.path.join(fold, "forests")
    os.makedirs(forests, exist_ok=True)
    forest_options = spec.get("forest", config["forest"])
    # Runs with learned channels read other folders: their options are part of the forest's name.
    first_key = digest(spec["train"], forest_options, *[spec[k[0]] for k in LEARNED_CHANNELS if k[0] in spec])
    train_works = learned_works(bin_dir, fold, spec, train_works, train_works, "train")
    first = os.path.join(forests, first_key + ".json")
    if not os.path.isfile(first):
        run([f"{bin_dir}/train-forest"] + train_works + spec["train"] + forest_options + ["-q", "-o", first])
    if "context" not in spec:
        return first, first
    second = os.path.join(forests, digest(first_key, spec["context"]) + ".json")
    if not os.path.isfile(second):
        ctx = context_works(bin_dir, fold, first, first_key, train_works, "train", ["--folds", str(CONTEXT_FOLDS)])
        run([f"{bin_dir}/train-forest"] + ctx + spec["context"] + forest_options + ["-q", "-o", second])
    return first, second


def context_works(bin_dir, fold, first, first_key, works, label, options=()):
    """add-context's work folders of `works` with the first forest's posteriors (made once per forest)."""
    ctx = os.path.join(fold, "context", f"{first_key}-{label}")
    if not os.path.isfile(os.path.join(ctx, ".done")):
        shutil.rmtree(ctx, ignore_errors=True)
        run([f"{bin_dir}/add-context", first] + works + list(options) + ["-q", "-o", ctx])
        open(os.path.join(ctx, ".done"), "w").close()
    return [os.path.join(ctx, os.path.basename(w)) for w in works]


# Channels learned per fold on its training folders: (run key, learning tool, adding tool, folder).
LEARNED_CHANNELS = (("textons", "learn-textons", "add-textons", "textons"),
                    ("hog_classes", "learn-hog-classes", "add-hog-classes", "hog-classes"))


def learned_works(bin_dir, fold, spec, train_works, works, label):
    """With "textons" and/or "hog_classes": the folders of `works` extended with those channels (each
    model learned on the fold's training folders once per options; a second kind extends the first's
    folders); otherwise `works` as they are."""
    keys = []
    for kind, learn, add, folder_name in LEARNED_CHANNELS:
        if kind not in spec:
            continue
        keys.append(digest(spec[kind], *keys))
        folder = os.path.join(fold, folder_name)
        model = os.path.join(folder, keys[-1] + ".json")
        if not os.path.isfile(model):
            os.makedirs(folder, exist_ok=True)
            run([f"{bin_dir}/{learn}"] + train_works + spec[kind] + ["-q", "-o", model])
        # Named by the folders they extend as well: the same channels over other folders (the people
        # detectors' or not) are other folders.
        out = os.path.join(folder, f"{keys[-1]}-{label}-{digest(sorted({os.path.dirname(w) for w in works}))[:6]}")
        if not os.path.isfile(os.path.join(out, ".done")):
            shutil.rmtree(out, ignore_errors=True)
            run([f"{bin_dir}/{add}", model] + works + ["-q", "-o", out])
            open(os.path.join(out, ".done"), "w").close()
        works = [os.path.join(out, os.path.basename(w)) for w in works]
    return works


def people_works(bin_dir, out, spec, train, test, phases):
    """With "people": the run's train, test and phase folders as add-people's folders that extend them
    (made once per options and side, for every fold: the detectors learn nothing from the folds);
    otherwise as they are."""
    if "people" not in spec:
        return train, test, phases
    key = digest(spec["people"])
    sides = {"train": list(train.values()), "test": list(test.values()) + [w for ws in phases.values() for w in ws]}
    for side, works in sides.items():
        folder = os.path.join(out, "people", f"{key}-{side}")
        if not os.path.isfile(os.path.join(folder, ".done")):
            shutil.rmtree(folder, ignore_errors=True)
            run([f"{bin_dir}/add-people"] + works + spec["people"] + ["-q", "-o", folder])
            open(os.path.join(folder, ".done"), "w").close()
    extended = lambda side, w: os.path.join(out, "people", f"{key}-{side}", os.path.basename(w))
    return ({r: extended("train", w) for r, w in train.items()}, {r: extended("test", w) for r, w in test.items()},
            {r: [extended("test", w) for w in ws] for r, ws in phases.items()})


def evaluate(bin_dir, spec, forest, works, folder, power):
    results = os.path.join(folder, "results.json")
    if not os.path.isfile(results):
        run([f"{bin_dir}/eval-forest", forest] + works + spec.get("eval", []) +
            ["--prior-power", str(power), "--no-pictures", "-q", "-o", folder])
    with open(results) as f:
        r = json.load(f)
    return {"global": r["global_accuracy"], "class_average": r["class_average_accuracy"], "mean_iou": r["mean_iou"],
            "per_class": {v["class"]: v["accuracy"] for v in r["per_class"]}}


def run_fold(bin_dir, config, name, held, train, test, phases):
    spec = config["runs"][name]
    train, test, phases = people_works(bin_dir, config["out"], spec, train, test, phases)
    fold = os.path.join(config["out"], "folds", held)
    train_works = [w for run_name, w in sorted(train.items()) if run_name != held]
    first, forest = train_run(bin_dir, config, spec, train_works, fold)
    first_key = os.path.splitext(os.path.basename(first))[0]
    sets = {"fold": phases.get(held, [test[held]])}
    if held in phases:
        sets["whole"] = [test[held]]  # a faster run as filmed, beside
    figures = {}
    os.makedirs(os.path.join(fold, name), exist_ok=True)
    for label, works in sets.items():
        works = learned_works(bin_dir, fold, spec, train_works, works, label)
        tested = context_works(bin_dir, fold, first, first_key, works, label) if "context" in spec else works
        for power in config["prior_power"]:
            figures[f"{label}@{power:g}"] = evaluate(bin_dir, spec, forest, tested,
                                                     os.path.join(fold, name, f"eval-{label}-p{power:g}"), power)
    print(f"{name} held out {held}: " + ", ".join(
        f"p{p:g} {100 * figures[f'fold@{p:g}']['global']:.1f} / {100 * figures[f'fold@{p:g}']['class_average']:.1f}"
        for p in config["prior_power"]), flush=True)
    return figures


# ---- summary ---------------------------------------------------------------------------------------

def mean_spread(values):
    values = [v for v in values if v is not None and not math.isnan(v)]
    if not values:
        return None, None
    return statistics.fmean(values), statistics.stdev(values) if len(values) > 1 else 0.0


def summarise(config, folds):
    summary = {}
    for name in config["runs"]:
        per_power = {}
        for power in config["prior_power"]:
            key = f"fold@{power:g}"
            entry = {}
            for metric in ("global", "class_average", "mean_iou"):
                m, s = mean_spread([folds[name][h][key][metric] for h in folds[name]])
                entry[metric] = {"mean": m, "spread": s}
            classes = next(iter(folds[name].values()))[key]["per_class"].keys()
            entry["per_class_mean"] = {c: mean_spread([folds[name][h][key]["per_class"].get(c) for h in folds[name]])[0]
                                       for c in classes}
            entry["whole"] = {h: f[f"whole@{power:g}"] for h, f in folds[name].items() if f"whole@{power:g}" in f}
            per_power[f"{power:g}"] = entry
        summary[name] = per_power
    return summary


def pct(x):
    return "-" if x is None else f"{100 * x:.1f}"


def markdown(config, summary):
    lines = ["| run | prior power | global | class avg | mIoU | faster runs whole (global / class avg) |",
             "|---|---|---|---|---|---|"]
    for name, per_power in summary.items():
        for power, e in per_power.items():
            cell = lambda m: f"{pct(e[m]['mean'])} ± {pct(e[m]['spread'])}"
            lines.append(f"| {name} | {power} | {cell('global')} | {cell('class_average')} | {cell('mean_iou')} | "
                         + "; ".join(f"{h}: {pct(w['global'])} / {pct(w['class_average'])}" for h, w in e["whole"].items())
                         + " |")
    return "\n".join(lines) + "\n"


def curve_figure(summary, path):
    """Global against class-average accuracy over the prior powers, one line per run: fold means with
    their spreads as error bars, each point named by its power."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for name, per_power in summary.items():
        powers = list(per_power)
        ca = [100 * per_power[p]["class_average"]["mean"] for p in powers]
        gl = [100 * per_power[p]["global"]["mean"] for p in powers]
        ax.errorbar(ca, gl, xerr=[100 * per_power[p]["class_average"]["spread"] for p in powers],
                    yerr=[100 * per_power[p]["global"]["spread"] for p in powers], marker="o", capsize=2, label=name)
        for p, x, y in zip(powers, ca, gl):
            ax.annotate(f"p={p}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xlabel("class-average accuracy, % (mean over held-out runs)")
    ax.set_ylabel("global accuracy, %")
    ax.set_title("CamVid leave-one-run-out: posterior / prior^p")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    tmp = path + ".partial.png"
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    os.replace(tmp, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("camvid")
    parser.add_argument("out")
    parser.add_argument("config")
    parser.add_argument("--reuse", help="a benchmark.sh OUT whose work folders are taken by symlink")
    parser.add_argument("--runs", help="only these runs of CONFIG, comma-separated")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="extractions at once")
    a = parser.parse_args()
    config = load_config(a.config)
    if a.runs:
        wanted = a.runs.split(",")
        unknown = [r for r in wanted if r not in config["runs"]]
        if unknown:
            fail(f"--runs: {', '.join(unknown)}: not in {a.config}")
        config["runs"] = {r: config["runs"][r] for r in wanted}
    if a.jobs < 1:
        fail("--jobs: expected at least 1")
    bin_dir = os.path.abspath(os.environ.get("SMSEG_BIN", "build/bin"))
    for tool in ("import-camvid", "extract-features", "train-forest", "eval-forest", "add-context", "learn-textons",
                 "add-textons", "add-people", "learn-hog-classes", "add-hog-classes"):
        if not os.access(os.path.join(bin_dir, tool), os.X_OK):
            fail(f"{bin_dir}/{tool}: missing (set SMSEG_BIN)")
    camvid = os.path.abspath(a.camvid)
    if not os.path.isfile(os.path.join(camvid, "frames.csv")):
        fail(f"{camvid}/frames.csv: missing (not a CamVid folder in the layout of ../shared/data/camvid)")
    out = os.path.abspath(a.out)
    os.makedirs(out, exist_ok=True)
    config["out"] = out
    if a.reuse and config["extract"] != BENCHMARK_EXTRACT:
        fail(f"--reuse: {a.config}'s extract options {config['extract']} are not benchmark.sh's {BENCHMARK_EXTRACT}")
    keep_extract_options(out, config["extract"])
    runs, phase_sequences = prepare_sequences(bin_dir, camvid, out)
    train, test, phases = prepare_works(bin_dir, out, a.reuse, config["extract"], runs, phase_sequences, a.jobs)
    folds = {name: {held: run_fold(bin_dir, config, name, held, train, test, phases) for held in sorted(runs)}
             for name in config["runs"]}
    summary = summarise(config, folds)
    record = {"config": {k: v for k, v in config.items() if k != "out"}, "folds": folds, "summary": summary}
    name = "cross-validation" + ("-" + a.runs.replace(",", "-") if a.runs else "")
    write_atomic(os.path.join(out, name + ".json"), json.dumps(record, indent=2) + "\n")
    table = markdown(config, summary)
    write_atomic(os.path.join(out, name + ".md"), table)
    curve_figure(summary, os.path.join(out, name + ".png"))
    sys.stdout.write(table)


if __name__ == "__main__":
    main()
