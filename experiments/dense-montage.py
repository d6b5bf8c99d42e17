"""The dense geometry channels of one frame next to its image and its true depth or labels (the pictures
of docs/stereo.md and docs/sfm.md).

Usage: python3 experiments/dense-montage.py WORK SEQUENCE FRAME OUT.png [TITLE]
WORK: a work folder made with `extract-features SEQUENCE -o WORK --dense` holding FRAME; SEQUENCE: its
sequence folder. The second panel is the true inverse depth when the frame has one (synthetic
sequences), else its label image. Reads the stored summed-area tables and differences them back into
per-pixel rasters.
"""
import json, os, sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
work, seq, frame, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
m = json.load(open(f"{work}/stacks.json"))
names = m["features"]
sat = np.load(f"{work}/stacks/{frame:06d}.sat.npy")
def raster(name):
    k = names.index(name)
    s = sat[k] if sat.shape[0] == len(names) else sat[..., k]
    return s[1:, 1:] - s[:-1, 1:] - s[1:, :-1] + s[:-1, :-1]
heading = sys.argv[5] if len(sys.argv) > 5 else f"extract-features --dense, frame {frame}"
manifest = json.load(open(f"{seq}/sequence.json"))
entry = manifest["frames"][frame]
path = lambda p: p if os.path.isabs(p) else os.path.join(seq, p)
left = plt.imread(path(entry["left"]))
valid = raster("fZV") > 0.5
if entry.get("gt_depth"):
    truth = np.load(path(entry["gt_depth"]))
    second = ("true inverse depth (1/m)", np.where(truth > 0, 1 / np.maximum(truth, 1e-6), np.nan), "viridis")
    vmax = np.nanpercentile(second[1], 99)
else:  # the label image, in the classes' colours when it holds class indices
    labels = plt.imread(path(entry["label"]))
    if labels.ndim == 2 and manifest["labels"].get("encoding") == "index":
        lut = np.zeros((256, 3))
        for c in manifest["labels"]["classes"] + [manifest["labels"].get("void", {"value": 255, "colour": [0, 0, 0]})]:
            lut[c["value"]] = np.array(c["colour"]) / 255
        labels = lut[np.round(labels * 255).astype(int) if labels.dtype != np.uint8 else labels]
    second = ("labels (not read by the channels)", labels, None)
    vmax = np.nanpercentile(np.where(valid, raster("fZI"), np.nan), 99)
panels = [("left image", left, None),
          second,
          ("dense inverse depth fZI (1/m)", np.where(valid, raster("fZI"), np.nan), "viridis"),
          ("height fZH (m)", np.where(valid, raster("fZH"), np.nan), "magma"),
          ("facing up fZU", np.where(valid, raster("fZU"), np.nan), "coolwarm"),
          ("depth edges fZE", np.where(valid, raster("fZE"), np.nan), "gray")]
fig, axes = plt.subplots(2, 3, figsize=(12, 6.2))
for ax, (title, img, cmap) in zip(axes.ravel(), panels):
    kw = {}
    if "inverse" in title: kw = dict(vmin=0, vmax=vmax)
    if title.startswith("facing"): kw = dict(vmin=-1, vmax=1)
    if title.startswith("depth edges"): kw = dict(vmin=0, vmax=0.2)
    im = ax.imshow(img, cmap=cmap, **kw)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
    if cmap: fig.colorbar(im, ax=ax, fraction=0.035)
fig.suptitle(f"{heading}; white: no dense depth", fontsize=11)
fig.tight_layout()
fig.savefig(out, dpi=80)
