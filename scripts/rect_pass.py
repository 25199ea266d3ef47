#!/usr/bin/env python3
"""The second pass of adaptive rays as rectangular partial renders (make
compare-adaptive; docs/studies.md "Adaptive rays"), timed against the mesh
camera's one process.

make SAMPLES=adaptive traces a refinement's extra rays through POV-Ray's
mesh camera, all tiles in one process. The other route POV-Ray offers is a
partial render of a rectangle (+SC/+EC columns, +SR/+ER rows), one
rectangle a process. This script renders the refined tiles of a refinement
(sirays refine's file) that way, supersampled on a regular s x s grid a
pixel (s = round(sqrt(refined rays per pixel)), the frame rendered at s
times its size, only the rectangle traced), in two layouts:

  tile  one process per refined tile;
  run   one process per run of adjacent refined tiles in a tile row.

Each process is scripts/render.sh (POV-Ray, its wall time from its
statistics, parse included); the processes run one after another, as the
mesh pass's one does. Prints a Markdown table and, with --out, writes it.

    rect_pass.py --refinement R.txt --scene scenes/objects.pov [--threads N]
        [--povopts "Declare=..."] [--out FILE]
"""
import argparse
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def read_refinement(path):
    words = open(path).read().split()
    if not words or words[0] != "sis-refinement":
        sys.exit(f"rect_pass.py: {path}: not a refinement (sirays refine's file)")
    get = dict(zip(words[:-1], words[1:]))
    W, H = (int(v) for v in get["frame"].split("x"))
    n = int(get["tiles"])
    tiles = [int(v) for v in words[words.index("tiles") + 2:][:n]]
    return W, H, int(get["tile"]), int(get["rays"]), tiles


def rectangles(W, H, T, tiles, layout):
    """(x0, y0, x1, y1) in output pixels, end exclusive."""
    cols = (W + T - 1) // T
    out = []
    for t in tiles:
        tx, ty = t % cols, t // cols
        x0, y0, x1, y1 = tx * T, ty * T, min(W, (tx + 1) * T), min(H, (ty + 1) * T)
        if layout == "run" and out and out[-1][1] == y0 and out[-1][2] == x0:
            out[-1] = (out[-1][0], y0, x1, y1)
        else:
            out.append((x0, y0, x1, y1))
    return out


def stats(path):
    out = {}
    for line in open(path):
        w = line.split()
        if len(w) >= 2:
            out[w[0]] = float(w[1])
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--refinement", required=True)
    p.add_argument("--scene", required=True, help="the scene's .pov")
    p.add_argument("--povopts", default="", help="extra POV-Ray options (the scene's Declare=...)")
    p.add_argument("--threads", type=int, default=0, help="POV-Ray's +WT (0: its default)")
    p.add_argument("--out", help="also write the table here")
    a = p.parse_args()
    W, H, T, R, tiles = read_refinement(a.refinement)
    s = max(1, round(R ** 0.5))
    if T * s < 2:
        # +EC1/+ER1 would be read as the fraction 1.0 (the whole frame)
        sys.exit(f"rect_pass.py: {a.refinement}: tiles of {T} pixels at {s} x {s} rays make "
                 "rectangles of one column, which POV-Ray cannot name")
    lines = [f"Rectangular partial renders of {len(tiles)} refined tiles of {T} x {T} pixels "
             f"({os.path.basename(a.refinement)}, {W} x {H}, {R} rays per refined pixel): "
             f"a regular {s} x {s} grid a pixel ({s * s} rays), the frame at {W * s} x {H * s}.", "",
             "| layout | POV-Ray processes | rays traced | wall s (sum) | parse s | trace s |",
             "| --- | --- | --- | --- | --- | --- |"]
    opts = a.povopts.split() + ([f"+WT{a.threads}"] if a.threads else [])
    with tempfile.TemporaryDirectory(prefix="rect-pass-") as d:
        for layout in ("tile", "run"):
            wall = parse = trace = 0.0
            rays = 0
            rects = rectangles(W, H, T, tiles, layout)
            for i, (x0, y0, x1, y1) in enumerate(rects):
                st = os.path.join(d, f"{layout}{i}.stats")
                # POV-Ray counts columns and rows from 1 (a value below 1 is a fraction)
                subprocess.run(["bash", os.path.join(ROOT, "scripts", "render.sh"), a.scene,
                                os.path.join(d, f"{layout}{i}.exr"), str(W * s), str(H * s)] + opts +
                               [f"+SC{x0 * s + 1}", f"+EC{x1 * s}", f"+SR{y0 * s + 1}", f"+ER{y1 * s}"],
                               check=True, env=dict(os.environ, RENDER_STATS=st))
                v = stats(st)
                wall += v.get("wall_s", 0)
                parse += v.get("parse_s", 0)
                trace += v.get("trace_s", 0)
                rays += int(v.get("pixels", 0))
                os.remove(os.path.join(d, f"{layout}{i}.exr"))
            lines.append(f"| {layout} | {len(rects)} | {rays} | {wall:.2f} | {parse:.2f} | {trace:.2f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
