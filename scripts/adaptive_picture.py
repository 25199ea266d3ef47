#!/usr/bin/env python3
"""adaptive_picture.py --refinement R.txt --image METHOD.png --out DIR/rays.png [--stats S]

Where the rays of an adaptive render went (make SAMPLES=adaptive): the
final image in grey, each refined tile tinted orange and outlined, enlarged
by pixel replication to at least 512 pixels wide; beside it DIR/rays.txt,
one line the scene's page shows under it (tiles refined, their rays per
pixel, the base's, the whole frame's, and the second pass's POV-Ray time
from the statistics). Both written to temporary names and renamed.
"""
import argparse
import os
import sys

import numpy as np
from PIL import Image


def read_refinement(path):
    keys, tiles = {}, []
    with open(path) as f:
        lines = f.read().split("\n")
    for i, line in enumerate(lines):
        w = line.split()
        if not w:
            continue
        if w[0] == "tiles":
            keys["tiles"] = int(w[1])
            tiles = [int(t) for t in " ".join(lines[i + 1:]).split()]
            break
        keys[w[0]] = w[1]
    if len(tiles) != keys.get("tiles", -1):
        sys.exit(f"adaptive_picture.py: {path}: not a refinement (sirays refine -o)")
    return keys, tiles


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--refinement", required=True)
    p.add_argument("--image", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--stats")
    a = p.parse_args()
    keys, tiles = read_refinement(a.refinement)
    W, H = (int(v) for v in keys["frame"].split("x"))
    T, rays, factor = int(keys["tile"]), int(keys["rays"]), float(keys["factor"])
    base = round(factor * factor)
    img = np.asarray(Image.open(a.image).convert("RGB"), dtype=np.float64) / 255
    if img.shape[:2] != (H, W):
        sys.exit(f"adaptive_picture.py: {a.image}: {img.shape[1]} x {img.shape[0]}, the refinement's frame is {W} x {H}")
    grey = img @ np.array([0.2126, 0.7152, 0.0722])
    out = np.repeat(grey[:, :, None], 3, axis=2) * 0.85
    cols = (W + T - 1) // T
    refined = np.zeros((H, W), bool)
    for t in tiles:
        tx, ty = t % cols, t // cols
        refined[ty * T:(ty + 1) * T, tx * T:(tx + 1) * T] = True
    orange = np.array([1.0, 0.55, 0.1])
    out[refined] = 0.5 * out[refined] + 0.5 * orange
    k = max(1, -(-512 // W))
    big = np.repeat(np.repeat(out, k, axis=0), k, axis=1)
    r = np.repeat(np.repeat(refined, k, axis=0), k, axis=1)
    edge = r & ~(np.roll(r, 1, 0) & np.roll(r, -1, 0) & np.roll(r, 1, 1) & np.roll(r, -1, 1))
    big[edge] = orange
    tmp = os.path.join(os.path.dirname(a.out) or ".", "." + os.path.basename(a.out) + ".tmp.png")
    Image.fromarray((np.clip(big, 0, 1) * 255 + 0.5).astype(np.uint8)).save(tmp)
    P = W * H
    npix = int(refined.sum())
    total = (base * P + (rays - base) * npix) / P
    line = (f"Where the rays went: {len(tiles)} of {cols * ((H + T - 1) // T)} tiles of {T} x {T} pixels "
            f"refined to {rays} rays per pixel (orange), {base} elsewhere: {total:.4g} rays per pixel "
            f"in all.")
    if a.stats and os.path.isfile(a.stats):
        st = dict(l.split()[:2] for l in open(a.stats) if len(l.split()) >= 2)
        if "wall_s" in st:
            line += (f" The second pass: {st.get('extra_rays', '?')} rays in {float(st['wall_s']):.2f} s "
                     f"of POV-Ray.")
    tmp_txt = os.path.join(os.path.dirname(a.out) or ".", ".rays.txt.tmp")
    with open(tmp_txt, "w") as f:
        f.write(line + "\n")
    os.replace(tmp, a.out)
    os.replace(tmp_txt, os.path.join(os.path.dirname(a.out) or ".", "rays.txt"))


if __name__ == "__main__":
    main()
