#!/usr/bin/env python3
"""Pyramids against maketx (make compare-mip [QUICK=1]; docs/studies.md).

For each scene, from one render at --factor of a --res frame: the levels
0..L-1 by siproject (min-error box, tent, cubic: the levels `siproject --mip`
writes, bit for bit; tests/test_mip.cpp) against maketx's levels of the same
render (its default box filter, --filter lanczos3, and lanczos3 with
--hicomp, its highlight compensation: the range compressed before the
filter and expanded after; maketx's level log2(factor) + j has level j's
size).

Measures per level:
  l2       continuous L2 error (RMS over the frame; the zone plate at 8 * 2^j
           points per level-j pixel and axis) of the approximation
           against the truth: the zone plate's closed form, else the render
           at --ref-factor. siproject: its level's coefficients. maketx: its
           level's pixels as a piecewise-constant image (the box space; a
           texture lookup with closest texels).
  shown    RMS of the displayed level against the truth's area averages over
           each pixel of the level (the reference render at --ref-factor
           projected onto the box space, an exact area average).
  negative samples below zero in the displayed level.
and the time and peak memory (RSS) of the whole pyramid: `siproject --mip`
against `maketx` and `maketx --filter lanczos3` from the same render
(medians of --repeat runs, /usr/bin/time).
Writes REPORT/mip.md and REPORT/mip.json.
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys

import numpy as np

import siproject
from renders import zp_k  # noqa: E402  (the Makefile's ZP_K)


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, **kw)


def render(args, scene, res, factor):
    path = os.path.join(args.out, "render", f"{scene}-{res}-f{factor}.exr")
    run(["make", "-s", "render", f"SCENE={scene}", f"RES={res}", f"FACTOR={factor}",
         f"OUT={args.out}", "PREBUILT=1"], stdout=subprocess.DEVNULL)
    return path


def timed(cmd):
    """(seconds, peak RSS in MiB) of one run."""
    r = subprocess.run(["/usr/bin/time", "-f", "%e %M"] + cmd, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    e, m = r.stderr.strip().splitlines()[-1].split()
    return float(e), float(m) / 1024


def sizes(w, h):
    out = [(w, h)]
    while w > 1 or h > 1:
        w, h = max(1, w // 2), max(1, h // 2)
        out.append((w, h))
    return out


def db(a, b):
    return 20 * math.log10(b / a) if a > 0 and b > 0 else float("nan")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", default="objects zoneplate checker")
    p.add_argument("--res", type=int, default=1024)
    p.add_argument("--factor", type=int, default=8)
    p.add_argument("--ref-factor", type=int, default=32)
    p.add_argument("--levels", type=int, default=6)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--siproject", default="build/tools/siproject")
    p.add_argument("--maketx", default="maketx")
    p.add_argument("--out", default="out")
    p.add_argument("--work", default="out/compare-mip")
    p.add_argument("--report", default="out/report/mip")
    args = p.parse_args()
    os.makedirs(args.work, exist_ok=True)
    os.makedirs(args.report, exist_ok=True)
    F, R = args.factor, args.res
    shift = int(round(math.log2(F)))
    if 2 ** shift != F:
        sys.exit("compare_mip.py: --factor must be a power of 2 (maketx's levels halve the render)")
    levels = sizes(R, R)[: args.levels]
    ours = [("box", "centred"), ("tent", "centred"), ("tent", "2x2"), ("cubic", "centred"), ("cubic", "2x2")]
    results = {"command": " ".join(sys.argv), "res": R, "factor": F, "ref_factor": args.ref_factor,
               "levels": levels, "scenes": {}}
    for scene in args.scenes.split():
        src = render(args, scene, R, F)
        ref_path = render(args, scene, R, args.ref_factor)
        ref = siproject.Reference(siproject.read_image(ref_path)) if scene != "zoneplate" else None
        K = zp_k(R) if scene == "zoneplate" else None

        def l2(k, j):
            # the closed form at 8 * 2^j points per level-j pixel and axis:
            # the same points over the frame at every level
            return (siproject.l2_error(k, zoneplate=K, samples_per_pixel=8 * 2 ** j) if K
                    else siproject.l2_error(k, ref))

        tx = {}
        for name, extra in (("maketx box", []), ("maketx lanczos3", ["--filter", "lanczos3"]),
                            ("maketx lanczos3 --hicomp", ["--filter", "lanczos3", "--hicomp"])):
            out = os.path.join(args.work, f"{scene}-{'-'.join(name.split()[1:]).strip('-')}.tx.exr")
            run([args.maketx, src, "-o", out] + extra, stdout=subprocess.DEVNULL)
            tx[name] = out
        rows = {}
        for j, (w, h) in enumerate(levels):
            area = siproject.project(ref_path, size=(w, h), generator="box", display="centred")
            row = {}
            for gen, disp in ours:
                k = siproject.coefficients(src, size=(w, h), generator=gen)
                shown = siproject.project(src, size=(w, h), generator=gen, display=disp)
                row[f"siproject {gen} {disp}"] = {
                    "l2": l2(k, j), "shown": float(np.sqrt(np.mean((shown - area) ** 2))),
                    "negative": int((shown < 0).sum())}
            for name, path in tx.items():
                lvl = os.path.join(args.work, f"{scene}-level.exr")
                run(["oiiotool", path, "--selectmip", str(shift + j), "-d", "float", "-o", lvl])
                img = siproject.read_image(lvl)
                assert img.shape[:2] == (h, w), (name, j, img.shape)
                k = siproject.coefficients(img, factor=1, generator="box")  # the pixels, as they are
                row[name] = {"l2": l2(k, j), "shown": float(np.sqrt(np.mean((img - area) ** 2))),
                             "negative": int((img < 0).sum())}
            rows[j] = row
        timing = {}
        mip = os.path.join(args.work, f"{scene}-mip.exr")
        for name, cmd in (("siproject --mip (cubic, 2x2)", [args.siproject, src, "-o", mip, "--factor", str(F), "--mip", "-q"]),
                          ("siproject --mip --generator box --display centred",
                           [args.siproject, src, "-o", mip, "--factor", str(F), "--mip", "-q", "--generator", "box", "--display", "centred"]),
                          ("maketx", [args.maketx, src, "-o", tx["maketx box"]]),
                          ("maketx --filter lanczos3", [args.maketx, src, "-o", tx["maketx lanczos3"], "--filter", "lanczos3"]),
                          ("maketx --filter lanczos3 --hicomp",
                           [args.maketx, src, "-o", tx["maketx lanczos3 --hicomp"], "--filter", "lanczos3", "--hicomp"])):
            runs = [timed(cmd) for _ in range(args.repeat)]
            timing[name] = {"seconds": statistics.median(r[0] for r in runs),
                            "peak_mib": statistics.median(r[1] for r in runs), "command": " ".join(cmd)}
        results["scenes"][scene] = {"render": src, "truth": f"zoneplate K={K}" if K else ref_path,
                                    "levels": rows, "timing": timing}
    with open(os.path.join(args.report, "mip.json"), "w") as f:
        json.dump(results, f, indent=1)
    write_md(results, os.path.join(args.report, "mip.md"))


def write_md(res, path):
    L = []
    L.append(f"# Pyramids: siproject's min-error levels against maketx\n")
    L.append(f"`{res['command']}`: {res['res']} x {res['res']} frame, render at factor {res['factor']}, "
             f"truth at factor {res['ref_factor']} (zone plate: its closed form).\n")
    for scene, s in res["scenes"].items():
        L.append(f"## {scene}\n")
        names = list(s["levels"][0].keys())
        for key, what in (("l2", "continuous L2 error (RMS over the frame)"),
                          ("shown", "displayed level against the truth's area averages (RMS)")):
            L.append(f"{what}:\n")
            L.append("| method | " + " | ".join(f"level {j} ({w}x{h})" for j, (w, h) in enumerate(res["levels"])) + " |")
            L.append("| --- |" + " --- |" * len(res["levels"]))
            for n in names:
                L.append(f"| {n} | " + " | ".join(f"{s['levels'][j][n][key]:.5f}" for j in range(len(res["levels"]))) + " |")
            L.append("")
        L.append("Goal checks (continuous L2, dB = 20 log10(other / cubic); cubic is `siproject cubic`'s coefficients):\n")
        L.append("| level | cubic vs maketx box (dB) | cubic vs maketx lanczos3 (dB) | "
                 "cubic vs lanczos3 --hicomp (dB) | >= 1 dB vs box | better than lanczos3 |")
        L.append("| --- | --- | --- | --- | --- | --- |")
        for j in range(len(res["levels"])):
            r = s["levels"][j]
            c = r["siproject cubic 2x2"]["l2"]
            a, b = db(c, r["maketx box"]["l2"]), db(c, r["maketx lanczos3"]["l2"])
            hc = db(c, r["maketx lanczos3 --hicomp"]["l2"])
            L.append(f"| {j} | {a:+.2f} | {b:+.2f} | {hc:+.2f} | {'yes' if a >= 1 else 'no'} | "
                     f"{'yes' if b > 0 else 'no'} |")
        L.append("")
        L.append("Negative samples in the displayed levels (all levels): " + ", ".join(
            f"{n} {sum(s['levels'][j][n]['negative'] for j in range(len(res['levels'])))}" for n in names) + "\n")
        L.append("Whole pyramid (median of runs, wall seconds and peak RSS):\n")
        L.append("| command | seconds | peak MiB |")
        L.append("| --- | --- | --- |")
        for n, t in s["timing"].items():
            L.append(f"| `{t['command']}` | {t['seconds']:.2f} | {t['peak_mib']:.0f} |")
        L.append("")
    with open(path, "w") as f:
        f.write("\n".join(L) + "\n")


if __name__ == "__main__":
    main()
