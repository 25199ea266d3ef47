#!/usr/bin/env python3
"""scene_page.py DIR METHOD...: DIR/index.html, the scene's images side by side.

Each METHOD's 8-bit image (DIR/METHOD.png, made by make) at its own size,
and two crops of 64 x 64 pixels enlarged 4x by pixel replication
(DIR/crops/METHOD-1.png, -2.png): the windows where the methods disagree
most (the standard deviation across them of each pixel's luminance, summed
over the window; the second at least two windows from the first). Below,
DIR/summary.txt, the time and high-pass share of each method. The page
marks on its body how many of its images loaded (data-loaded="N of M"), so
that a headless browser can check them. Files are written to temporary
names and renamed.
"""
import html
import os
import sys

import numpy as np
from PIL import Image

CROP, ZOOM = 64, 4


def windows(score, size, count=2):
    h, w = score.shape
    s = np.zeros((h + 1, w + 1))
    s[1:, 1:] = score.cumsum(0).cumsum(1)
    picked = []
    for _ in range(count):
        best, corner = -1.0, None
        for y in range(0, max(1, h - size + 1), 4):
            for x in range(0, max(1, w - size + 1), 4):
                if any(abs(y - py) < 2 * size and abs(x - px) < 2 * size for py, px in picked):
                    continue
                v = s[min(h, y + size), min(w, x + size)] - s[y, min(w, x + size)] - s[min(h, y + size), x] + s[y, x]
                if v > best:
                    best, corner = v, (y, x)
        if corner is None:
            break
        picked.append(corner)
    return picked


def save(img, path):
    tmp = path + ".tmp.png"
    try:
        img.save(tmp, optimize=True)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    folder, methods = sys.argv[1], sys.argv[2:]
    images = {}
    for m in methods:
        path = os.path.join(folder, m + ".png")
        if not os.path.isfile(path):
            sys.exit(f"scene_page.py: {path} is missing")
        images[m] = np.asarray(Image.open(path).convert("RGB"))
    lum = np.stack([a @ np.array([0.2126, 0.7152, 0.0722]) for a in images.values()])
    size = min(CROP, *lum.shape[1:])
    corners = windows(lum.std(axis=0), size)
    os.makedirs(os.path.join(folder, "crops"), exist_ok=True)
    for m, a in images.items():
        for i, (y, x) in enumerate(corners, 1):
            crop = a[y:y + size, x:x + size].repeat(ZOOM, axis=0).repeat(ZOOM, axis=1)
            save(Image.fromarray(crop), os.path.join(folder, "crops", f"{m}-{i}.png"))
    summary_path = os.path.join(folder, "summary.txt")
    summary = open(summary_path).read() if os.path.isfile(summary_path) else "(no summary.txt)"
    scene = os.path.basename(os.path.normpath(folder))
    where = ", ".join(f"({x}, {y})" for y, x in corners)
    cards = []
    for m in methods:
        crops = "".join(f'<img class="crop" src="crops/{html.escape(m)}-{i}.png" alt="{html.escape(m)} crop {i}">'
                        for i in range(1, len(corners) + 1))
        cards.append(f'<figure><figcaption>{html.escape(m)}</figcaption>'
                     f'<a href="{html.escape(m)}.png"><img class="full" src="{html.escape(m)}.png" alt="{html.escape(m)}"></a>'
                     f'<div>{crops}</div></figure>')
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(scene)}: every method</title>
<style>body{{font-family:sans-serif;margin:1em}}.grid{{display:flex;flex-wrap:wrap;gap:12px}}
figure{{margin:0;width:260px}}img.full{{width:256px;height:auto;image-rendering:auto}}
img.crop{{width:126px;image-rendering:pixelated;margin:1px}}figcaption{{font-weight:bold}}pre{{background:#f4f4f4;padding:8px}}</style>
</head><body data-loaded="pending">
<h1>{html.escape(scene)}: the final image by every method</h1>
<p>Each image as formed (8-bit sRGB; click for full size) and two {size} x {size} crops enlarged {ZOOM}x where
the methods differ most (top-left corners {html.escape(where)}). Made by <code>make</code>
(scripts/scene_page.py); the float results are the <code>.exr</code> files beside this page.</p>
<div class="grid">{''.join(cards)}</div>
<h2>Summary</h2><pre>{html.escape(summary)}</pre>
<script>
window.addEventListener("load", function () {{
  var imgs = document.images, ok = 0;
  for (var i = 0; i < imgs.length; i++) if (imgs[i].complete && imgs[i].naturalWidth > 0) ok++;
  document.body.setAttribute("data-loaded", ok + " of " + imgs.length);
}});
</script></body></html>
"""
    tmp = os.path.join(folder, ".index.html.tmp")
    try:
        with open(tmp, "w") as f:
            f.write(page)
        os.replace(tmp, os.path.join(folder, "index.html"))
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


if __name__ == "__main__":
    main()
