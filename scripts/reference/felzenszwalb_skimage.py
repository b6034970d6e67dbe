#!/usr/bin/env python3
"""Reference segmentations for decompose::video::segment (decompose/src/video/segment/):
scikit-image's `felzenszwalb` and its region-adjacency-graph merge by mean colour.

Needs scikit-image, numpy and Pillow: `python3 -m pip install --user scikit-image pillow`
(the committed values were made with scikit-image 0.26.0, numpy 2.4.6, scipy 1.17.1,
Pillow 13.0.0; the versions are recorded in the JSON).

Inputs: the three photographs of fixtures/photos (scikit-image's own astronaut, coffee and
chelsea, licences in fixtures/README.md), shrunk by an integer factor with Pillow's BOX filter
(exact block means) to about 150 px so the Rust test stays fast, and written as 8-bit PNG into
fixtures/video/segment/. Both sides read those PNG bytes: skimage as uint8 (img_as_float64
divides by 255), the Rust test with `LoadOptions { linear: true }` (u8 / 255, no sRGB decoding).

Writes into fixtures/video/segment/:
- `NAME.png`: the shrunk input;
- `NAME_fh_S_SIGMA_MIN.png`: `skimage.segmentation.felzenszwalb(img, scale=S, sigma=SIGMA,
  min_size=MIN)` labels as 16-bit grayscale PNG;
- `NAME_merge_T.png`: the labels of the issue's setting (S=50, sigma=0.8, min=256) after
  `skimage.graph.rag_mean_color(img_float, labels, connectivity=2)` and
  `merge_hierarchical(thresh=T, merge_func=mean colour, weight_func=distance of means)`, the
  merge of the skimage gallery example "RAG merging";
- `reference.json`: segment counts of every map above, the settings and versions.

Usage (from the workspace root):  python3 scripts/reference/felzenszwalb_skimage.py
"""

import datetime
import json
import pathlib

import numpy as np
import PIL
import scipy
import skimage
from PIL import Image
from skimage import graph
from skimage.segmentation import felzenszwalb

ROOT = pathlib.Path(__file__).resolve().parents[2]
OUT = ROOT / "fixtures" / "video" / "segment"

# (name, source file, integer shrink factor)
IMAGES = [
    ("chelsea", "chelsea.jpg", 3),
    ("coffee", "coffee.jpg", 4),
    ("astronaut", "astronaut.jpg", 4),
]
# (scale, sigma, min_size): the setting first, then a finer and a smoother one.
SETTINGS = [(50, 0.8, 256), (100, 0.5, 50), (20, 1.0, 20)]
MERGE_THRESHOLDS = [5 / 255, 0.05, 0.1]


def merge_mean_color(g, src, dst):
    g.nodes[dst]["total color"] += g.nodes[src]["total color"]
    g.nodes[dst]["pixel count"] += g.nodes[src]["pixel count"]
    g.nodes[dst]["mean color"] = g.nodes[dst]["total color"] / g.nodes[dst]["pixel count"]


def weight_mean_color(g, src, dst, n):
    diff = np.linalg.norm(g.nodes[dst]["mean color"] - g.nodes[n]["mean color"])
    return {"weight": diff}


def save_labels(path, labels):
    assert labels.max() < 65536
    Image.fromarray(labels.astype(np.uint16)).save(path)


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    result = {
        "generated": datetime.date.today().isoformat(),
        "script": "scripts/reference/felzenszwalb_skimage.py",
        "versions": {
            "scikit-image": skimage.__version__,
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "Pillow": PIL.__version__,
        },
        "images": {},
    }
    for name, src, factor in IMAGES:
        photo = Image.open(ROOT / "fixtures" / "photos" / src).convert("RGB")
        w, h = photo.size
        small = photo.resize((w // factor, h // factor), Image.Resampling.BOX)
        small.save(OUT / f"{name}.png", optimize=True)
        img = np.asarray(Image.open(OUT / f"{name}.png").convert("RGB"))
        entry = {"width": img.shape[1], "height": img.shape[0], "felzenszwalb": [], "merge": []}
        for scale, sigma, min_size in SETTINGS:
            labels = felzenszwalb(img, scale=scale, sigma=sigma, min_size=min_size)
            file = f"{name}_fh_{scale}_{sigma}_{min_size}.png"
            save_labels(OUT / file, labels)
            entry["felzenszwalb"].append(
                {
                    "scale": scale,
                    "sigma": sigma,
                    "min_size": min_size,
                    "segments": int(labels.max()) + 1,
                    "labels": file,
                }
            )
        base = felzenszwalb(img, scale=50, sigma=0.8, min_size=256)
        img_float = skimage.util.img_as_float64(img)
        for t in MERGE_THRESHOLDS:
            rag = graph.rag_mean_color(img_float, base, connectivity=2)
            merged = graph.merge_hierarchical(
                base,
                rag,
                thresh=t,
                rag_copy=False,
                in_place_merge=True,
                merge_func=merge_mean_color,
                weight_func=weight_mean_color,
            )
            _, merged = np.unique(merged, return_inverse=True)
            merged = merged.reshape(base.shape)
            file = f"{name}_merge_{t:.4f}.png"
            save_labels(OUT / file, merged)
            entry["merge"].append(
                {"threshold": t, "segments": int(merged.max()) + 1, "labels": file}
            )
        result["images"][name] = entry
    (OUT / "reference.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps({k: [f["segments"] for f in v["felzenszwalb"]] + [m["segments"] for m in v["merge"]] for k, v in result["images"].items()}))


if __name__ == "__main__":
    main()
