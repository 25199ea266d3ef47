#!/usr/bin/env python3
"""docs_picture.py SCENE_DIR OUT.png: the README's picture (make docs).

The same crop of the scene's images by the conventional tent, Mitchell-
Netravali and min-error cubic with the 2x2 display, siproject's default
(SCENE_DIR/{conv-tent,mitchell,me-cubic-2x2}.png,
made by make), side by side, enlarged 3x by pixel replication, each named.
The crop is the 96 x 96 window where the three disagree most (the standard
deviation across them of each pixel's 8-bit luminance, summed over the
window). Written to a temporary name and renamed.
"""
import os
import sys

import numpy as np
from PIL import Image, ImageDraw

METHODS = [("conv-tent", "conventional tent"), ("mitchell", "Mitchell-Netravali"),
           ("me-cubic-2x2", "min-error cubic, 2x2 display")]
SIZE, ZOOM, CAPTION = 96, 3, 22


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    folder, out = sys.argv[1:]
    images = []
    for name, _ in METHODS:
        path = os.path.join(folder, name + ".png")
        if not os.path.isfile(path):
            sys.exit(f"docs_picture.py: {path} is missing (run make)")
        images.append(np.asarray(Image.open(path).convert("RGB")))
    lum = np.stack([a @ np.array([0.2126, 0.7152, 0.0722]) for a in images])
    score = lum.std(axis=0)
    h, w = score.shape
    s = np.zeros((h + 1, w + 1))
    s[1:, 1:] = score.cumsum(0).cumsum(1)
    best, corner = -1.0, (0, 0)
    for y in range(0, h - SIZE + 1, 8):
        for x in range(0, w - SIZE + 1, 8):
            v = s[y + SIZE, x + SIZE] - s[y, x + SIZE] - s[y + SIZE, x] + s[y, x]
            if v > best:
                best, corner = v, (y, x)
    y, x = corner
    tile = SIZE * ZOOM
    sheet = Image.new("RGB", (len(images) * tile + (len(images) - 1) * 4, tile + CAPTION), "white")
    draw = ImageDraw.Draw(sheet)
    for i, (a, (_, label)) in enumerate(zip(images, METHODS)):
        crop = a[y:y + SIZE, x:x + SIZE].repeat(ZOOM, axis=0).repeat(ZOOM, axis=1)
        sheet.paste(Image.fromarray(crop), (i * (tile + 4), CAPTION))
        draw.text((i * (tile + 4) + 4, 4), label, fill="black")
    tmp = out + ".tmp.png"
    try:
        sheet.save(tmp, optimize=True)
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


if __name__ == "__main__":
    main()
