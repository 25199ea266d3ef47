#!/usr/bin/env python3
"""The animation study (make compare-anim [QUICK=1]; docs/studies.md,
"Animations"): space-time min-error against the sub-frame average on the
sweep (scenes/sweep.pov), whose image is known in closed form at every time.

Sub-frames are make's own targets (make anim-subframes: POV-Ray at Clock=t,
sis:time recorded), K = 2, 4, 8 per frame at 24 fps. Every sub-frame is
projected spatially once (min-error cubic, centred display); a frame is a
weighted sum of those images (siproject.frame_weights; siproject --fps forms
the same frames, tests/python/test_frames.py), so every temporal method is
measured on the same spatial images. The truth of a frame is the exact
shutter integral of the closed form at the render's sample positions
(Gauss-Legendre in time for the zone plate; the square wave's antiderivative
for the bars), projected by the same spatial method: the errors are the
temporal ones. PSNR (peak 1) over the frames away from the sub-frames' ends.

Also: frame-rate conversion (24 fps sub-frames shown at 60 fps, and 60 at
24) against frames formed from sub-frames rendered for the target rate; the
render's own floor (POV-Ray's half-float sub-frames against the closed form
at their times); siproject --fps's time and peak memory.

    compare_anim.py --work DIR --report DIR [--quick]
"""

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

import siproject

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import anim_times  # noqa: E402
import atomic  # noqa: E402

FPS = 24.0
# name, pattern, speed (frame widths per second). The bars' speed is not a
# simple fraction of a sample per sub-frame: at 0.25 the edge moves 1/3 of a
# render sample per sub-frame at K = 8 (64 x 4 samples, 24 fps), the edges'
# places repeat every 3 sub-frames, and the error depends on that accident
# rather than on K (measured: the average's sample error equal at K = 4 and 8,
# exact at K = 16).
FULL_CASES = (("zoneplate-slow", "zoneplate", 0.25), ("zoneplate-fast", "zoneplate", 2.0),
              ("bars", "bars", 0.23))
QUICK_CASES = (("zoneplate-slow", "zoneplate", 0.25),)
# label, frame_weights keywords
METHODS = (
    ("average", dict(method="conventional")),
    ("D0", dict(degree=0)),
    ("D1", dict(degree=1)),
    ("D3", dict(degree=3)),
    ("D3 hold, step 1/fps", dict(degree=3, model="hold", step=1 / FPS)),
)
SHUTTERS = ("180", "360")
SPATIAL = dict(generator="cubic", method="min-error", display="centred")


def make_subframes(a, case, frames, k, fps):
    """make anim-subframes; returns (paths, times, seconds of make)."""
    name, pattern, speed = case
    out = os.path.join(a.work, name)
    cmd = ["make", "-C", ROOT, "--no-print-directory", f"-j{a.jobs}", f"OUT={os.path.abspath(out)}",
           f"SIPROJECT={a.siproject}", "SCENE=sweep", f"RES={a.res}", f"FACTOR={a.factor}",
           f"FRAMES={frames}", f"SUBFRAMES={k}", f"RENDER_FPS={fps:g}", f"SWEEP_V={speed}",
           f"SWEEP_PATTERN={pattern}", f"ZP_NYQUIST={a.zp_nyquist}", "anim-subframes"]
    env = {e: v for e, v in os.environ.items() if e not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    t0 = time.perf_counter()
    r = subprocess.run(cmd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    if r.returncode != 0:
        sys.exit(f"compare_anim.py: make anim-subframes ({name}, K={k}, {fps:g} fps) failed")
    seconds = time.perf_counter() - t0
    d = os.path.join(out, "anim", f"sweep-{a.res}-f{a.factor}-{fps:g}fps-k{k}")
    n = frames * k
    paths = [os.path.join(d, f"sub.{i:04d}.exr") for i in range(n)]
    times = np.array(anim_times.times(frames, k, fps))
    for p, t in zip(paths, times):
        if abs(float(siproject_time(p)) - t) > 1e-9:
            sys.exit(f"compare_anim.py: {p}: sis:time is not {t}")
    return paths, times, seconds


def siproject_time(path):
    out = subprocess.run(["oiiotool", "--info", "-v", path], capture_output=True, text=True).stdout
    for line in out.splitlines():
        line = line.strip()
        if line.startswith("sis:time:"):
            return line.split(":", 2)[2].strip().strip('"')
    sys.exit(f"compare_anim.py: {path}: no sis:time")


def sample_grid(a):
    W = a.res * a.factor
    u = (np.arange(W) + 0.5) / W
    return np.meshgrid(u, u)  # U[j, i] = u_i, V[j, i] = v_j


def closed_form(a, pattern, speed, U, V, t):
    x = U - speed * t
    if pattern == "zoneplate":
        k = a.zp_nyquist * math.pi * a.res
        return 0.5 + 0.5 * np.cos(k * ((x - 0.5) ** 2 + (V - 0.5) ** 2))
    p = 1 / 8
    return ((x / p - np.floor(x / p)) < 0.5).astype(np.float64)


def truth_samples(a, pattern, speed, U, V, o, c):
    """The shutter's box average of the closed form at every sample."""
    if pattern == "zoneplate":
        # 64 Gauss-Legendre nodes: the fast case turns the phase by at most
        # about 6 cycles over a 360-degree shutter at a sample; the rule's
        # error there is far below double rounding
        x, w = np.polynomial.legendre.leggauss(64)
        acc = np.zeros_like(U)
        for xi, wi in zip(x, w):
            acc += wi * closed_form(a, pattern, speed, U, V, 0.5 * (o + c) + 0.5 * (c - o) * xi)
        return acc / 2
    p = 1 / 8

    def G(y):  # integral over [0, y] of the square wave
        q = y / p
        return p * (0.5 * np.floor(q) + np.minimum(q - np.floor(q), 0.5))

    return (G(U - speed * o) - G(U - speed * c)) / (speed * (c - o))


def spatial(a, src):
    """The spatial projection, as float64; the sweep is grey: its red channel."""
    x = siproject.project(src, size=(a.res, a.res), **SPATIAL).astype(np.float64)
    return x[..., 0] if x.ndim == 3 else x


def psnr(mse):
    return float("inf") if mse == 0 else -10 * math.log10(mse)


def interior_frames(times, fps, shutter, margin_frames):
    """Frames whose shutter lies at least margin_frames frame intervals
    inside the sub-frames' span."""
    lo = times[0] - 0.5 * (times[1] - times[0])
    hi = times[-1] + 0.5 * (times[-1] - times[-2])
    ang = float(shutter)
    f0 = math.ceil((lo + margin_frames / fps) * fps - 1e-9)
    f1 = math.floor((hi - margin_frames / fps) * fps - ang / 360 + 1e-9)
    return list(range(f0, f1 + 1))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--work", required=True)
    p.add_argument("--report", required=True)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--siproject", default=os.path.join(ROOT, "build", "tools", "siproject"))
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    p.add_argument("--zp-nyquist", type=float, default=0.7)
    a = p.parse_args(argv)
    a.siproject = os.path.abspath(a.siproject)
    a.res, a.factor = (32, 4) if a.quick else (64, 4)
    cases = QUICK_CASES if a.quick else FULL_CASES
    Ks = (2, 4) if a.quick else (2, 4, 8)
    frames = 8 if a.quick else 12
    margin = 2  # frame intervals from either end of the span
    os.makedirs(a.report, exist_ok=True)
    U, V = sample_grid(a)
    rows, per_frame, floors, renders = [], [], [], []
    images = {}
    for case in cases:
        name, pattern, speed = case
        for k in Ks:
            paths, times, secs = make_subframes(a, case, frames, k, FPS)
            renders.append(dict(case=name, K=k, fps=FPS, subframes=len(paths), make_s=round(secs, 2)))
            stills = [spatial(a, q) for q in paths]
            images[(name, k, FPS)] = (stills, times)
            # the render's floor: POV-Ray's sub-frames against the closed form
            mid = len(paths) // 2
            exact = spatial(a, closed_form(a, pattern, speed, U, V, times[mid]).astype(np.float32))
            floors.append(dict(case=name, K=k, psnr=round(psnr(np.mean((stills[mid] - exact) ** 2)), 2)))
            for shutter in SHUTTERS:
                fr = interior_frames(times, FPS, shutter, margin)
                every = interior_frames(times, FPS, shutter, 0)  # the end frames too
                truths = {}
                for f in every:
                    o = f / FPS
                    c = o + float(shutter) / 360 / FPS
                    truths[f] = spatial(a, truth_samples(a, pattern, speed, U, V, o, c).astype(np.float32))
                for label, kw in METHODS:
                    errs = {}
                    for f in every:
                        w = siproject.frame_weights(times, fps=FPS, time=f / FPS, shutter=shutter, **kw)
                        est = sum(wk * s for wk, s in zip(w, stills) if wk != 0)
                        errs[f] = float(np.mean((est - truths[f]) ** 2))
                        per_frame.append(dict(case=name, K=k, shutter=shutter, method=label, frame=f,
                                              psnr=round(psnr(errs[f]), 3)))
                    rows.append(dict(case=name, K=k, shutter=shutter, method=label, frames=len(fr),
                                     psnr=round(psnr(float(np.mean([errs[f] for f in fr]))), 2)))
                    ends = [f for f in every if f not in fr]
                    if label in ("average", "D3") and ends:
                        rows.append(dict(case=name, K=k, shutter=shutter, method=f"{label}, end frames",
                                         frames=len(ends),
                                         psnr=round(psnr(float(np.mean([errs[f] for f in ends]))), 2)))
                print(f"compare_anim: {name} K={k} shutter {shutter}: " +
                      ", ".join(f"{r['method']} {r['psnr']}" for r in rows if r["case"] == name and
                                r["K"] == k and r["shutter"] == shutter), flush=True)

    # frame-rate conversion: zoneplate-slow, 180 degrees, K = 4
    conversion = []
    if not a.quick:
        case = cases[0]
        name, pattern, speed = case
        k = 4
        duration = frames / FPS
        paths60, times60, secs = make_subframes(a, case, int(round(duration * 60)), k, 60.0)
        renders.append(dict(case=name, K=k, fps=60, subframes=len(paths60), make_s=round(secs, 2)))
        stills60 = [spatial(a, q) for q in paths60]
        stills24, times24 = images[(name, k, FPS)]
        for src_fps, dst_fps, src, dst in ((24, 60, (stills24, times24), (stills60, times60)),
                                           (60, 24, (stills60, times60), (stills24, times24))):
            fr_src = set(interior_frames(src[1], dst_fps, "180", margin * dst_fps / FPS))
            fr_dst = set(interior_frames(dst[1], dst_fps, "180", margin * dst_fps / FPS))
            fr = sorted(fr_src & fr_dst)
            res = {}
            for label, stills, times, kw in (
                    (f"converted from {src_fps} fps (D3)", src[0], src[1], dict(degree=3)),
                    (f"rendered for {dst_fps} fps (D3)", dst[0], dst[1], dict(degree=3)),
                    (f"rendered for {dst_fps} fps (average)", dst[0], dst[1], dict(method="conventional"))):
                errs = []
                for f in fr:
                    o = f / dst_fps
                    c = o + 0.5 / dst_fps
                    tr = spatial(a, truth_samples(a, pattern, speed, U, V, o, c).astype(np.float32))
                    w = siproject.frame_weights(times, fps=dst_fps, time=f / dst_fps, shutter="180", **kw)
                    est = sum(wk * s for wk, s in zip(w, stills) if wk != 0)
                    errs.append(float(np.mean((est - tr) ** 2)))
                res[label] = psnr(float(np.mean(errs)))
                conversion.append(dict(direction=f"{src_fps} -> {dst_fps}", method=label, frames=len(fr),
                                       psnr=round(res[label], 2)))
            print(f"compare_anim: conversion {src_fps} -> {dst_fps}: {res}", flush=True)

    # siproject --fps: time and peak memory, K = largest, the first case
    cost = []
    name = cases[0][0]
    kmax = Ks[-1]
    d = os.path.join(a.work, name, "anim", f"sweep-{a.res}-f{a.factor}-{FPS:g}fps-k{kmax}")
    subs = [os.path.join(d, f"sub.{i:04d}.exr") for i in range(frames * kmax)]
    for label, opts in (("space-time D3 (defaults)", []),
                        ("average", ["--method", "conventional", "--generator", "box"])):
        out = os.path.join(a.work, "cost")
        os.makedirs(out, exist_ok=True)
        best = None
        for _ in range(3):
            t0 = time.perf_counter()
            r = subprocess.run(["/usr/bin/time", "-f", "%M", a.siproject, *subs, "--fps", "24", "--size",
                                str(a.res), "--display", "centred", "-q", *opts, "-d", "float",
                                "-o", os.path.join(out, "f.#.exr")], capture_output=True, text=True)
            secs = time.perf_counter() - t0
            if r.returncode != 0:
                sys.exit(f"compare_anim.py: siproject --fps failed: {r.stderr}")
            rss = int(r.stderr.strip().splitlines()[-1])
            best = (secs, rss) if best is None or secs < best[0] else best
        cost.append(dict(method=label, subframes=len(subs), seconds=round(best[0], 3), peak_kb=best[1]))

    write_report(a, rows, per_frame, floors, renders, conversion, cost, Ks, cases)
    return 0


def write_report(a, rows, per_frame, floors, renders, conversion, cost, Ks, cases):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import io
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    atomic.write_atomic(os.path.join(a.report, "anim.csv"), buf.getvalue())
    atomic.write_atomic(os.path.join(a.report, "anim.json"),
                        json.dumps(dict(rows=rows, per_frame=per_frame, floors=floors, renders=renders,
                                        conversion=conversion, cost=cost,
                                        res=a.res, factor=a.factor), indent=1))
    fig, axes = plt.subplots(len(cases), len(SHUTTERS), figsize=(5.2 * len(SHUTTERS), 3.6 * len(cases)),
                             squeeze=False)
    for i, case in enumerate(cases):
        for j, shutter in enumerate(SHUTTERS):
            ax = axes[i][j]
            for label, _ in METHODS:
                ys = [next(r["psnr"] for r in rows if r["case"] == case[0] and r["K"] == k and
                           r["shutter"] == shutter and r["method"] == label) for k in Ks]
                ax.plot(Ks, ys, marker="o", label=label)
            ax.set_xscale("log", base=2)
            ax.set_xticks(Ks, [str(k) for k in Ks])
            ax.set_xlabel("sub-frames per frame K")
            ax.set_ylabel("PSNR (dB)")
            ax.set_title(f"{case[0]}, {shutter} degrees")
            ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.report, "psnr-vs-k.png"), dpi=110)
    plt.close(fig)

    def table(keys, items):
        out = ["| " + " | ".join(keys) + " |", "|" + " --- |" * len(keys)]
        out += ["| " + " | ".join(str(it[k]) for k in keys) + " |" for it in items]
        return "\n".join(out)

    lines = [f"# Animations: space-time min-error against the sub-frame average",
             "",
             f"scenes/sweep.pov at {a.res} x {a.res}, factor {a.factor}, 24 fps; spatial projection "
             "min-error cubic, centred, the same for every temporal method; PSNR (peak 1) of the frames "
             "at least two frame intervals inside the sub-frames' span against the closed form's shutter "
             "integral (the rows \"end frames\": the frames nearer the ends). "
             "D0, D1, D3: space-time min-error, the cubic model and the sub-frames' spacing as the step "
             "(siproject's defaults, D3); `D3 hold, step 1/fps`: the hold model on the frame interval.",
             "", "| case | pattern | speed (frame widths/s) | output pixels per frame |",
             "| --- | --- | --- | --- |"]
    for name, pattern, speed in cases:
        lines.append(f"| {name} | {pattern} | {speed} | {speed * a.res / FPS:.3f} |")
    lines += ["", "![PSNR against K](psnr-vs-k.png)", ""]
    for case in cases:
        for shutter in SHUTTERS:
            lines.append(f"## {case[0]}, {shutter} degrees\n")
            hdr = ["method"] + [f"K={k}" for k in Ks]
            items = []
            for label in [m for m, _ in METHODS] + ["average, end frames", "D3, end frames"]:
                it = {"method": label}
                for k in Ks:
                    it[f"K={k}"] = next((r["psnr"] for r in rows if r["case"] == case[0] and r["K"] == k and
                                         r["shutter"] == shutter and r["method"] == label), "")
                items.append(it)
            lines += [table(hdr, items), ""]
    if conversion:
        lines += ["## Frame-rate conversion (zoneplate-slow, 180 degrees, K = 4)", "",
                  table(["direction", "method", "frames", "psnr"], conversion), ""]
    lines += ["## The render's floor (a POV-Ray half-float sub-frame against the closed form)", "",
              table(["case", "K", "psnr"], floors), "",
              "## siproject --fps: time and peak memory (best of 3)", "",
              table(["method", "subframes", "seconds", "peak_kb"], cost), "",
              "## Renders (make anim-subframes; make_s is this run's, near 0 when they were made before)", "",
              table(["case", "K", "fps", "subframes", "make_s"], renders), ""]
    md = "\n".join(lines)
    atomic.write_atomic(os.path.join(a.report, "anim.md"), md)
    body = []
    for line in md.splitlines():
        if line.startswith("# "):
            body.append(f"<h1>{line[2:]}</h1>")
        elif line.startswith("## "):
            body.append(f"<h2>{line[3:]}</h2>")
        elif line.startswith("!["):
            body.append('<img src="psnr-vs-k.png" alt="PSNR against K">')
        elif line.startswith("|"):
            if set(line.replace("|", "").split()) == {"---"}:
                continue
            cells = [c.strip() for c in line.strip("|").split("|")]
            body.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
        elif line:
            body.append(f"<p>{line}</p>")
    html, in_table = [], False
    for b in body:
        if b.startswith("<tr>") and not in_table:
            html.append("<table>")
            in_table = True
        if not b.startswith("<tr>") and in_table:
            html.append("</table>")
            in_table = False
        html.append(b)
    if in_table:
        html.append("</table>")
    page = ("<!doctype html><html><head><meta charset='utf-8'><title>Animations</title><style>"
            "body{font-family:sans-serif;margin:1.5em;max-width:70em} table{border-collapse:collapse;margin:.5em 0}"
            "td{border:1px solid #ccc;padding:2px 8px;text-align:right} img{max-width:100%}</style></head><body>"
            + "\n".join(html) + "</body></html>")
    atomic.write_atomic(os.path.join(a.report, "index.html"), page)
    print(f"compare_anim: {os.path.join(a.report, 'index.html')}")


if __name__ == "__main__":
    sys.exit(main())
