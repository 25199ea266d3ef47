#!/usr/bin/env python3
"""scene_page.py DIR METHOD[=OPTIONS]...: DIR/index.html, the scene's images side by side.

Each METHOD's 8-bit image (DIR/METHOD.png, made by make) at its own size,
and two crops of 64 x 64 pixels enlarged 4x by pixel replication
(DIR/crops/METHOD-1.png, -2.png), shown at that enlargement (256 x 256 CSS
pixels, never smoothed) and opened full size on a click: the windows where
the methods disagree most (the standard deviation across them of each
pixel's luminance, summed over the window; the second at least two windows
from the first). An adaptive render's DIR/rays.png (where its rays went,
scripts/adaptive_picture.py) is shown after them with DIR/rays.txt under
it. OPTIONS, siproject's options of the method (make passes
them), spell the method out where the reader meets its short name. Below,
DIR/summary.txt, the time and high-pass share of each method. The page
marks on its body how many of its images loaded (data-loaded="N of M") and
how many crops are shown at their enlargement (data-crops="N of M"), so
that a headless browser can check them. Files are written to temporary
names and renamed.
"""
import html
import os
import sys

import numpy as np
from PIL import Image

CROP, ZOOM = 64, 4

# How the page spells out siproject's names.
METHOD_WORDS = {"min-error": "min-error (orthogonal projection onto the space)",
                "conventional": "conventional (normalised weighted average)"}
GENERATOR_WORDS = {"box": "box", "tent": "tent (linear B-spline)", "quadratic": "quadratic B-spline",
                   "cubic": "cubic B-spline", "mitchell": "Mitchell-Netravali (B = C = 1/3)",
                   "gaussian": "Gaussian", "catmull-rom": "Catmull-Rom", "lanczos3": "Lanczos 3",
                   "hex-hat": "hexagonal hat box spline", "hex-quartic": "hexagonal quartic box spline"}
DISPLAY_WORDS = {"centred": "sampled at pixel centres", "2x2": "sampled at 2 x 2 points (+-1/4) per pixel",
                 "pixel": "averaged over each pixel"}


def spelled_out(options):
    """The method siproject's options name, in words ("" when none given)."""
    words = options.split()
    if not words:
        return ""
    given = {words[i]: words[i + 1] for i in range(len(words) - 1) if words[i].startswith("--")}
    generator = given.get("--generator", given.get("--filter", "cubic"))
    bspline = generator in ("box", "tent", "quadratic", "cubic") or generator.startswith(("bspline:", "hex-"))
    method = given.get("--method", "min-error" if bspline else "conventional")
    display = given.get("--display", "2x2" if method == "min-error" else "centred")
    lattice = " on the hexagonal lattice" if given.get("--lattice") in ("hex", "hexagonal") else ""
    return (f"{METHOD_WORDS.get(method, method)}, {GENERATOR_WORDS.get(generator, generator)}{lattice}, "
            f"{DISPLAY_WORDS.get(display, display)}")


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
    folder = sys.argv[1]
    methods, described = [], {}
    for arg in sys.argv[2:]:
        name, _, options = arg.partition("=")
        methods.append(name)
        described[name] = spelled_out(options)
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
    shown = size * ZOOM  # CSS pixels: the crop at its enlargement
    cards = []
    for m in methods:
        e = html.escape(m)
        crops = "".join(f'<a href="crops/{e}-{i}.png"><img class="crop" src="crops/{e}-{i}.png" '
                        f'width="{shown}" height="{shown}" alt="{e} crop {i}, {ZOOM}x"></a>'
                        for i in range(1, len(corners) + 1))
        words = f'<p class="words">{html.escape(described[m])}</p>' if described[m] else ""
        cards.append(f'<figure><figcaption><b>{e}</b>{words}</figcaption>'
                     f'<a href="{e}.png"><img class="full" src="{e}.png" alt="{e}"></a>'
                     f'<div class="crops">{crops}</div></figure>')
    # an adaptive render's picture of where its rays went (make SAMPLES=adaptive)
    if os.path.isfile(os.path.join(folder, "rays.png")):
        caption_path = os.path.join(folder, "rays.txt")
        caption = open(caption_path).read().strip() if os.path.isfile(caption_path) else "Where the rays went."
        cards.append(f'<figure><figcaption><b>rays</b><p class="words">{html.escape(caption)}</p></figcaption>'
                     f'<a href="rays.png"><img class="full" src="rays.png" alt="where the rays went"></a>'
                     f'</figure>')
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(scene)}: every method</title>
<style>body{{font-family:sans-serif;margin:1em}}.grid{{display:flex;flex-wrap:wrap;gap:16px}}
figure{{margin:0}}img.full{{width:256px;height:auto;image-rendering:auto}}
.crops{{display:flex;gap:4px}}.crops a{{line-height:0}}
img.crop{{width:{shown}px;height:{shown}px;image-rendering:pixelated;image-rendering:crisp-edges}}
figcaption{{max-width:{2 * shown + 4}px}}p.words{{margin:0.2em 0 0.4em;font-size:90%;color:#333}}
pre{{background:#f4f4f4;padding:8px}}</style>
</head><body data-loaded="pending" data-crops="pending">
<h1>{html.escape(scene)}: the final image by every method</h1>
<p>Each image as formed (8-bit sRGB; click for full size) and two {size} x {size} crops enlarged {ZOOM}x
(each pixel a {ZOOM} x {ZOOM} block; click for the crop alone) where the methods differ most (top-left
corners {html.escape(where)}). The short names: <b>me-</b> min-error, the orthogonal projection onto
the space of the generator; <b>conv-</b> or a filter's name alone, conventional, the normalised weighted
average of the samples under the filter; <b>-2x2</b> the approximation sampled at four points per pixel,
else at pixel centres. Made by <code>make</code> (scripts/scene_page.py); the float results are the
<code>.exr</code> files beside this page.</p>
<div class="grid">{''.join(cards)}</div>
<h2>Summary</h2><pre>{html.escape(summary)}</pre>
<script>
window.addEventListener("load", function () {{
  var imgs = document.images, ok = 0;
  for (var i = 0; i < imgs.length; i++) if (imgs[i].complete && imgs[i].naturalWidth > 0) ok++;
  document.body.setAttribute("data-loaded", ok + " of " + imgs.length);
  var crops = document.querySelectorAll("img.crop"), right = 0;
  for (var j = 0; j < crops.length; j++) {{
    var c = crops[j], r = c.getBoundingClientRect();
    if (r.width == {shown} && r.height == {shown} && c.naturalWidth == {shown} &&
        getComputedStyle(c).imageRendering != "auto") right++;
  }}
  document.body.setAttribute("data-crops", right + " of " + crops.length);
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
