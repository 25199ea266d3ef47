#!/usr/bin/env python3
"""The sample patterns compared (make compare-samples): for every scene,
pattern, density and seed, the render make made (renders are make targets:
out/compare-samples*/render/SCENE-RES-fFACTOR[-PATTERN-sSEED].exr, named as
the Makefile names them), projected by each method through the module; the
continuous L2 error against the truth (the zone plate's closed form, or the
regular reference render at --ref-factor), the displayed image's RMS error
against the same method's image of the reference (the zone plate: its
closed form at the pixel centres), the high-pass share above 0.25
cycles/pixel, their mean and spread max - min across seeds, and the
projection time. Writes REPORT/samples.md, samples.csv and a chart
(error against rays per pixel by pattern, per method).

    compare_samples.py --work DIR --report DIR --scenes "..." --res N
        --factors "2 4" --seeds "0 1" --ref-factor 8 --zp-nyquist 0.7
"""

import argparse
import csv
import math
import os
import time

import numpy as np

import siproject

METHODS = {
    "conv-tent": dict(generator="tent", method="conventional", display="centred"),
    "mitchell": dict(generator="mitchell", method="conventional", display="centred"),
    "me-tent": dict(generator="tent", method="min-error", display="centred"),
    "me-cubic": dict(generator="cubic", method="min-error", display="centred"),
    "me-cubic-2x2": dict(generator="cubic", method="min-error", display="2x2"),
}
PATTERNS = ("regular", "jitter", "sobol")


def render_path(work, scene, res, factor, pattern, seed):
    tag = "" if pattern == "regular" else f"-{pattern}-s{seed}"
    return os.path.join(work, "render", f"{scene}-{res}-f{factor}{tag}.exr")


def zoneplate(x, y, w, h, k):
    u, v = x / w, y / h
    return 0.5 + 0.5 * np.cos(k * ((u - 0.5) ** 2 + (v - 0.5) ** 2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--report", required=True)
    ap.add_argument("--scenes", required=True)
    ap.add_argument("--res", type=int, required=True)
    ap.add_argument("--factors", required=True)
    ap.add_argument("--seeds", required=True)
    ap.add_argument("--ref-factor", required=True)
    ap.add_argument("--zp-nyquist", type=float, default=0.7)
    ap.add_argument("--border", type=float, default=4)
    a = ap.parse_args()
    W = H = a.res
    zp_k = float("%.6f" % (a.zp_nyquist * math.pi * W))  # as the Makefile declares ZP_K
    seeds = a.seeds.split()
    rows = []
    ys, xs = np.mgrid[0:H, 0:W] + 0.5
    for scene in a.scenes.split():
        truth = None
        if scene != "zoneplate":
            ref = render_path(a.work, scene, a.res, a.ref_factor, "regular", 0)
            truth = siproject.Reference(siproject.read_image(ref), border=a.border)
            shown = {m: siproject.project(ref, size=(W, H), **kw) for m, kw in METHODS.items()}
        else:
            z = zoneplate(xs, ys, W, H, zp_k)[..., None]
            shown = {m: z for m in METHODS}
        for factor in a.factors.split():
            rays = float(factor) ** 2
            for pattern in PATTERNS:
                for seed in (seeds[:1] if pattern == "regular" else seeds):
                    path = render_path(a.work, scene, a.res, factor, pattern, seed)
                    for m, kw in METHODS.items():
                        t = time.perf_counter()
                        k = siproject.coefficients(path, size=(W, H), generator=kw["generator"], method=kw["method"])
                        image = k.resample(display=kw["display"])
                        seconds = time.perf_counter() - t
                        if truth is None:
                            l2 = siproject.l2_error(k, zoneplate=zp_k, border=a.border)
                        else:
                            l2 = truth.l2_error(k)
                        b = int(a.border)
                        s = shown[m][b:H - b, b:W - b, :1]
                        rms = float(np.sqrt(np.mean((image[b:H - b, b:W - b, :1] - s) ** 2)))
                        hp = float(siproject.highpass_share(image, 0.25))
                        rows.append(dict(scene=scene, pattern=pattern, rays=rays, seed=seed, method=m,
                                         l2=l2, rms=rms, hp=hp, seconds=seconds))
    os.makedirs(a.report, exist_ok=True)
    with open(os.path.join(a.report, "samples.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    # summary: mean and spread across seeds
    groups = {}
    for r in rows:
        groups.setdefault((r["scene"], r["method"], r["rays"], r["pattern"]), []).append(r)
    lines = [f"# Sample patterns ({W} x {H}, seeds {', '.join(seeds)}, reference: the zone plate's closed form, "
             f"else the regular render at factor {a.ref_factor}; border {a.border:g} px)", "",
             "![error against rays per pixel](samples.png)", "",
             "| scene | method | rays/px | pattern | L2 error | spread | displayed RMS | spread | hp>0.25 | time (s) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for (scene, m, rays, pattern), g in groups.items():
        l2 = np.array([r["l2"] for r in g]); rms = np.array([r["rms"] for r in g])
        lines.append(f"| {scene} | {m} | {rays:g} | {pattern} | {l2.mean():.5f} | {np.ptp(l2):.5f} | "
                     f"{rms.mean():.5f} | {np.ptp(rms):.5f} | {np.mean([r['hp'] for r in g]):.4f} | "
                     f"{np.mean([r['seconds'] for r in g]):.3f} |")
    with open(os.path.join(a.report, "samples.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scenes = a.scenes.split()
    fig, axes = plt.subplots(len(scenes), len(METHODS), figsize=(3 * len(METHODS), 2.6 * len(scenes)),
                             squeeze=False)
    for i, scene in enumerate(scenes):
        for j, m in enumerate(METHODS):
            ax = axes[i][j]
            for pattern in PATTERNS:
                pts = sorted((rays, np.mean([r["l2"] for r in g])) for (s, mm, rays, p), g in groups.items()
                             if s == scene and mm == m and p == pattern)
                ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=pattern)
            ax.set_xscale("log", base=2)
            ax.set_title(f"{scene} {m}", fontsize=8)
            if i == len(scenes) - 1:
                ax.set_xlabel("rays per pixel")
            if j == 0:
                ax.set_ylabel("L2 error")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(a.report, "samples.png"), dpi=80)
    print(f"compare-samples: {os.path.join(a.report, 'samples.md')}")


if __name__ == "__main__":
    main()
