# Figures of run-experiment results (JSON Lines, one record per point), drawn like the thesis figures.
# export-notebooks embeds this file in every notebook it writes, so that a notebook runs on its own
# (Debian's python3-matplotlib; no other package). A figure spec (from the experiment config):
#   {"id": "4.4a", "title": "...", "kind": "line" | "surface" | "windows" | "confusion",
#    "x": PARAM, "y": METRIC, "z": METRIC (surface), "series": PARAM (one line per value),
#    "series_labels": {value: legend text}, "where": {PARAM: value | [values] | {"min": a, "max": b}},
#    "xlabel", "ylabel", "zlabel", "ylim": [lo, hi]}
# PARAM is a parameter of the point (record["point"]), METRIC a field of the record. A metric that is an
# object (nodes_per_feature) gives one line per member. Points sharing x within a series are averaged.
import json
import math

import matplotlib
import matplotlib.pyplot as plt


def load_records(path):
    """The records of an experiment.jsonl (a half-written last line is skipped)."""
    records = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            try:
                records.append(json.loads(line))
            except json.JSONDecodeError:
                pass
    return records


def value(record, key):
    point = record.get("point", {})
    return point[key] if key in point else record.get(key)


def key_text(v):
    return v if isinstance(v, str) else json.dumps(v)


def matches(record, where):
    for key, cond in (where or {}).items():
        v = value(record, key)
        if isinstance(cond, list):
            ok = v in cond
        elif isinstance(cond, dict):
            ok = v is not None and ("min" not in cond or v >= cond["min"]) and ("max" not in cond or v <= cond["max"])
        else:
            ok = v == cond
        if not ok:
            return False
    return True


def _number(v):
    return float("nan") if v is None else float(v)


def _title(spec):
    import textwrap
    text = "Figure %s: %s" % (spec["id"], spec.get("title", "")) if "id" in spec else spec.get("title", "")
    return textwrap.fill(text, 72)


def _no_data(ax, spec):
    ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)
    ax.set_title(_title(spec), fontsize=10)


def line_figure(records, spec):
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    x_key, y_key, s_key = spec["x"], spec.get("y", "global_accuracy"), spec.get("series")
    labels = spec.get("series_labels", {})
    lines = {}  # legend -> {x: [y...]}
    order = []
    for r in records:
        x = value(r, x_key)
        y = value(r, y_key)
        if x is None or y is None:
            continue
        s = key_text(value(r, s_key)) if s_key else ""
        items = y.items() if isinstance(y, dict) else [("", y)]
        for member, v in items:
            name = labels.get(s, s) if s_key else ""
            if member:
                name = (name + ": " if name else "") + member
            if name not in lines:
                lines[name] = {}
                order.append(name)
            lines[name].setdefault(x, []).append(_number(v))
    if not lines:
        _no_data(ax, spec)
        return fig
    for name in order:
        xs = sorted(lines[name])
        ys = [sum(lines[name][x]) / len(lines[name][x]) for x in xs]
        ax.plot(xs, ys, marker="o" if len(xs) <= 12 else None, markersize=4, label=name or None)
    ax.set_xlabel(spec.get("xlabel", x_key))
    ax.set_ylabel(spec.get("ylabel", y_key))
    if "ylim" in spec:
        ax.set_ylim(*spec["ylim"])
    if len(order) > 1 or order[0]:
        ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title(_title(spec), fontsize=10)
    fig.tight_layout()
    return fig


def surface_figure(records, spec):
    x_key, y_key, z_key = spec["x"], spec["y"], spec.get("z", "global_accuracy")
    cells = {}
    for r in records:
        x, y, z = value(r, x_key), value(r, y_key), value(r, z_key)
        if x is not None and y is not None and z is not None:
            cells.setdefault((x, y), []).append(float(z))
    xs = sorted({k[0] for k in cells})
    ys = sorted({k[1] for k in cells})
    if len(xs) < 2 or len(ys) < 2:
        fig, ax = plt.subplots(figsize=(6.4, 4.4))
        if not cells:
            _no_data(ax, spec)
            return fig
        for y in ys:  # too few values for a surface: one line per y
            pts = sorted((x, sum(v) / len(v)) for (x, yy), v in cells.items() if yy == y)
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label="%s = %s" % (y_key, y))
        ax.set_xlabel(spec.get("xlabel", x_key))
        ax.set_ylabel(spec.get("zlabel", z_key))
        ax.legend(fontsize=8)
        ax.set_title(_title(spec), fontsize=10)
        fig.tight_layout()
        return fig
    fig = plt.figure(figsize=(7, 5.6))
    ax = fig.add_subplot(projection="3d")
    fig.subplots_adjust(left=0.0, right=0.94, bottom=0.02, top=0.95)
    ax.view_init(elev=25, azim=-125)
    X = [[x for x in xs] for _ in ys]
    Y = [[y for _ in xs] for y in ys]
    Z = [[(sum(cells[(x, y)]) / len(cells[(x, y)])) if (x, y) in cells else math.nan for x in xs] for y in ys]
    import numpy as np  # matplotlib depends on numpy
    ax.plot_surface(np.array(X), np.array(Y), np.array(Z), cmap="viridis", edgecolor="k", linewidth=0.2)
    ax.set_xlabel(spec.get("xlabel", x_key))
    ax.set_ylabel(spec.get("ylabel", y_key))
    ax.set_zlabel(spec.get("zlabel", z_key))
    ax.set_title(_title(spec), fontsize=10)
    return fig


def windows_figure(records, spec):
    fig, axes = plt.subplots(2, 2, figsize=(8, 6))
    total = None
    for r in records:
        h = r.get("windows")
        if not h or not h.get("dx"):
            continue
        if total is None:
            total = {k: list(h[k]) for k in ("dx", "dy", "w", "h")}
            total["bounds"] = h["bounds"]
        elif h["bounds"] == total["bounds"]:
            for k in ("dx", "dy", "w", "h"):
                total[k] = [a + b for a, b in zip(total[k], h[k])]
    if total is None:
        for ax in axes.flat:
            _no_data(ax, spec)
        return fig
    b = total["bounds"]
    panels = [("dx", -b["max_dx"], "(a) X offset", "Sampling window X offset"),
              ("dy", -b["max_dy"], "(b) Y offset", "Sampling window Y offset"),
              ("w", 1, "(c) Width", "Sampling window width"),
              ("h", 1, "(d) Height", "Sampling window height")]
    for ax, (k, first, caption, label) in zip(axes.flat, panels):
        ax.bar([first + i for i in range(len(total[k]))], total[k], width=0.9)
        ax.set_xlabel(label)
        ax.set_ylabel("Windows chosen")
        ax.set_title(caption, fontsize=9)
    n = int(sum(total["w"]))
    fig.suptitle("%s (%d windows)" % (_title(spec), n), fontsize=10)
    fig.tight_layout()
    return fig


def confusion_figure(records, spec):
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    if not records:
        _no_data(ax, spec)
        return fig
    r = records[0]
    classes, counts = r["classes"], r["confusion"]
    rows = []
    for row in counts:
        s = sum(row)
        rows.append([c / s if s else math.nan for c in row])
    ax.imshow(rows, cmap="Blues", vmin=0, vmax=1)
    for i, row in enumerate(rows):
        for j, v in enumerate(row):
            if not math.isnan(v):
                ax.text(j, i, "%.3f" % v, ha="center", va="center", fontsize=7, color="white" if v > 0.6 else "black")
    ax.set_xticks(range(len(classes)), classes, rotation=45, ha="right")
    ax.set_yticks(range(len(classes)), classes)
    ax.set_xlabel("Output")
    ax.set_ylabel("Ground truth")
    ax.set_title("%s\nglobal %.1f%%, class-average %.1f%%" % (
        _title(spec), 100 * _number(r.get("global_accuracy")), 100 * _number(r.get("class_average_accuracy"))), fontsize=10)
    fig.tight_layout()
    return fig


def plot_figure(records, spec, png=None):
    """Draws one figure of the spec from the records matching spec["where"]; saves it as PNG if asked."""
    chosen = [r for r in records if matches(r, spec.get("where"))]
    kind = spec.get("kind", "line")
    draw = {"line": line_figure, "surface": surface_figure, "windows": windows_figure,
            "confusion": confusion_figure}.get(kind)
    if draw is None:
        raise ValueError("figure %s: unknown kind %r" % (spec.get("id"), kind))
    fig = draw(chosen, spec)
    if png:  # atomically: a temporary file, then rename
        import os
        fig.savefig(png + ".tmp", dpi=100, format="png")
        os.replace(png + ".tmp", png)
    return fig
