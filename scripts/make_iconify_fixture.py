#!/usr/bin/env python3
"""Cut the small Iconify fixture (fixtures/iconify/noto-subset/) out of the real
@iconify-json/noto@1.2.9 package, keeping its JSON structure: a few icons, their plain aliases,
one hidden (deprecated) icon, and the matching categories of metadata.json.

Usage: scripts/make_iconify_fixture.py PATH/TO/node_modules/@iconify-json/noto OUT_DIR
(the package is installed by scripts/fetch-dev-data under .cache/style-data/.src)."""
import json
import os
import sys

src, out = sys.argv[1], sys.argv[2]
icons = json.load(open(os.path.join(src, "icons.json")))
meta = json.load(open(os.path.join(src, "metadata.json")))
keep = ["dog-face", "sun", "red-heart", "person", "counterclockwise-arrows-button", "0"]
subset = {k: v for k, v in icons.items() if k not in ("icons", "aliases")}
subset["icons"] = {k: icons["icons"][k] for k in keep}
subset["aliases"] = {k: v for k, v in icons["aliases"].items() if v["parent"] in keep}
cats = {c: [n for n in names if n in keep] for c, names in meta["categories"].items()}
os.makedirs(out, exist_ok=True)
json.dump(subset, open(os.path.join(out, "icons.json"), "w"), indent=1)
json.dump({"categories": {c: n for c, n in cats.items() if n}}, open(os.path.join(out, "metadata.json"), "w"), indent=1)
for name in ("info.json",):
    open(os.path.join(out, name), "w").write(open(os.path.join(src, name)).read())
