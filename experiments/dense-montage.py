"""The dense geometry channels of one frame next to its image and true depth (docs/stereo.md's picture).

Usage: python3 experiments/dense-montage.py WORK SEQUENCE FRAME OUT.png
WORK: a work folder made with `extract-features SEQUENCE -o WORK --dense` holding FRAME; SEQUENCE: a
synthetic sequence (its depth/ folder holds the true depth). Reads the stored summed-area tables and
differences them back into per-pixel rasters.
"""
import json, sys
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
left = plt.imread(f"{seq}/left/{frame:06d}.png")
truth = np.load(f"{seq}/depth/{frame:06d}.npy")
inv_truth = np.where(truth > 0, 1 / np.maximum(truth, 1e-6), np.nan)
valid = raster("fZV") > 0.5
panels = [("left image", left, None),
          ("true inverse depth (1/m)", inv_truth, "viridis"),
          ("dense inverse depth fZI (1/m)", np.where(valid, raster("fZI"), np.nan), "viridis"),
          ("height fZH (m)", np.where(valid, raster("fZH"), np.nan), "magma"),
          ("facing up fZU", np.where(valid, raster("fZU"), np.nan), "coolwarm"),
          ("depth edges fZE", np.where(valid, raster("fZE"), np.nan), "gray")]
fig, axes = plt.subplots(2, 3, figsize=(12, 6.2))
vmax = np.nanpercentile(inv_truth, 99)
for ax, (title, img, cmap) in zip(axes.ravel(), panels):
    kw = {}
    if "inverse" in title: kw = dict(vmin=0, vmax=vmax)
    if title.startswith("facing"): kw = dict(vmin=-1, vmax=1)
    if title.startswith("depth edges"): kw = dict(vmin=0, vmax=0.2)
    im = ax.imshow(img, cmap=cmap, **kw)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
    if cmap: fig.colorbar(im, ax=ax, fraction=0.035)
fig.suptitle(f"extract-features --dense, synthetic corridor (seed 1), frame {frame}; white: no dense depth", fontsize=11)
fig.tight_layout()
fig.savefig(out, dpi=80)
