#!/usr/bin/env python3
"""Stability where methods fail (issue 6): too few rays, noise, edges, HDR,
numerics, and what each remedy costs. Writes OUT/index.html with its charts,
and every number in OUT/stability.json and OUT/*.csv.

    stability.py --build build --out out/report/stability [--quick]

Renders are make's render targets (scripts/renders.py) in
OUT/../../stability-render/ (make render OUT=...), remade under the
Makefile's one staleness rule (scene, povray.ini, size, factor, options). Every method and
remedy is projected, and measured (continuous L2 error, display RMS,
overshoot and negatives), by the Python module siproject; the synthetic
studies (noise gain, step response, prefilter numerics) come from the
sistability tool.
"""
import argparse
import csv
import html
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import matplotlib
import numpy as np

try:
    import siproject
except ImportError as e:
    sys.exit(f"stability.py: the Python module siproject is missing ({e}): run make build")

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from renders import RenderError, make_render  # noqa: E402

# siproject's keywords of each method and remedy (the Makefile's METHOD_OPTS_*).
METHODS = {
    "box": dict(generator="box", method="conventional", display="centred"),
    "conv-tent": dict(generator="tent", method="conventional", display="centred"),
    "mitchell": dict(generator="mitchell", method="conventional", display="centred"),
    "me-tent": dict(generator="tent", method="min-error", display="centred"),
    "me-cubic": dict(generator="cubic", method="min-error", display="centred"),
    "me-tent-2x2": dict(generator="tent", method="min-error", display="2x2"),
    "me-cubic-2x2": dict(generator="cubic", method="min-error", display="2x2"),
}
REMEDIES = {
    "none": {},
    "clamp zero": dict(clamp="zero"),
    "clamp local": dict(clamp="local"),
    "highlight-compress": dict(highlight_compress=True),
}
# simetrics' default points per output pixel for the zone plate's closed form
ZONEPLATE_SPP = 8


def fail(msg):
    print(f"stability.py: {msg}", file=sys.stderr)
    sys.exit(1)


def run(cmd, capture=True):
    r = subprocess.run(cmd, capture_output=capture, text=True)
    if r.returncode != 0:
        fail(f"{' '.join(cmd)} exited with {r.returncode}:\n{r.stderr}")
    return r.stdout


def render(tools, work, scene, res, factor):
    """The render of SCENE at RES x RES output pixels and FACTOR, made by make
    in WORK (the Makefile's render target and staleness rule; the zone
    plate's ZP_K declared by it, 0.7 of Nyquist). Returns its path and
    POV-Ray's wall time when it was rendered."""
    try:
        path, stats, _ = make_render(work, scene, res, factor, zp_nyquist=0.7, build=tools.build)
    except RenderError as e:
        fail(str(e))
    return path, stats["wall_s"]


class Tools:
    def __init__(self, build):
        self.build = build
        self.sistability = os.path.join(build, "tools/sistability")
        if not os.access(self.sistability, os.X_OK):
            fail(f"{self.sistability} is missing: run make build")


def coefficients_of(display_options):
    """The keywords of siproject.coefficients(): a method's, without its display."""
    return {k: v for k, v in display_options.items() if k not in ("display", "clamp")}


def checked(call, *args, **kwargs):
    try:
        return call(*args, **kwargs)
    except (ValueError, OSError, RuntimeError) as e:
        fail(str(e))


def zoneplate_k(width, nyquist=0.7):
    return nyquist * math.pi * width


def factor_sweep(tools, work, res, factors):
    """L2 error against the zone plate's closed form, per method and factor."""
    k = zoneplate_k(res)
    rows = []
    for f in factors:
        src, t_render = render(tools, work, "zoneplate", res, f)
        for m, opts in METHODS.items():
            if m.endswith("-2x2"):
                continue  # the display does not change f_app: same error as its centred twin
            c = checked(siproject.coefficients, src, size=res, **coefficients_of(opts))
            rows.append({"factor": f, "method": m,
                         "l2_error": checked(siproject.l2_error, c, zoneplate=float(f"{k:.6f}"),
                                             samples_per_pixel=ZONEPLATE_SPP, border=2),
                         "render_s": t_render})
    return rows


def crossover(rows, a, b):
    """Smallest factor from which method a's error stays below method b's."""
    fs = sorted({r["factor"] for r in rows})
    err = {(r["method"], r["factor"]): r["l2_error"] for r in rows}
    win = None
    for f in reversed(fs):
        if err[(a, f)] < err[(b, f)]:
            win = f
        else:
            break
    return win


def edges_study(tools, work, res, factor, ref_factor):
    src, _ = render(tools, work, "edges", res, factor)
    ref, _ = render(tools, work, "edges", res, ref_factor)
    samples, truth = siproject.read_image(src), siproject.read_image(ref)
    rows = []
    for m, opts in METHODS.items():
        c = checked(siproject.coefficients, samples, size=res, **coefficients_of(opts))
        image = checked(c.resample, res, display=opts["display"])
        o = checked(siproject.overshoot, image, samples, border=2)
        rows.append({"method": m, "max_overshoot": o["max_overshoot"],
                     "max_undershoot": o["max_undershoot"],
                     "pixels_out_of_range": o["pixels_out_of_range"], "pixels": o["pixels"],
                     "l2_error": checked(siproject.l2_error, c, truth, border=2)})
    return rows


def hdr_study(tools, work, res, factor, ref_factor):
    src, _ = render(tools, work, "hdr", res, factor)
    ref, _ = render(tools, work, "hdr", res, ref_factor)
    samples = siproject.read_image(src)
    # The display the reference would give: the area average of its samples.
    ref_display = checked(siproject.project, ref, size=res, **METHODS["box"])
    rows = []
    for m in ("box", "conv-tent", "mitchell", "me-tent", "me-cubic", "me-cubic-2x2"):
        for remedy, ropts in REMEDIES.items():
            if remedy != "none" and not m.startswith("me-"):
                continue
            out = os.path.join(work, f"hdr-{m}-{remedy.replace(' ', '-')}.exr")
            image = checked(siproject.project, samples, size=res, **METHODS[m], **ropts)
            checked(siproject.write_image, out, image)
            o = checked(siproject.overshoot, image, samples, border=2)
            rows.append({"method": m, "remedy": remedy, "negative_pixels": o["negative_pixels"],
                         "negative_energy": o["negative_energy"], "min": o["min"], "max": o["max"],
                         "max_undershoot": o["max_undershoot"],
                         "pixels_out_of_range": o["pixels_out_of_range"],
                         "display_rms": checked(siproject.rms_difference, image, ref_display, border=2),
                         "image": os.path.basename(out)})
    return rows, src, ref_display


def read_exr(path):
    """Float array H x W x C of an image, read by the module."""
    return siproject.read_image(path).astype(np.float64)


def viz_signed(exr, png, scale=4):
    """Luminance tone-mapped x / (1 + x) in grey, negative values in red
    (intensity sqrt(|v| / 0.05), saturating at -0.05), upscaled by pixel
    replication so each output pixel stays visible."""
    a = read_exr(exr)
    lum = a[:, :, :3].mean(axis=2) if a.shape[2] >= 3 else a[:, :, 0]
    pos = np.clip(lum, 0, None)
    grey = pos / (1 + pos)
    neg = np.sqrt(np.clip(-lum / 0.05, 0, 1))
    rgb = np.stack([np.maximum(grey, neg), grey * (1 - neg), grey * (1 - neg)], axis=2)
    rgb = np.kron(rgb, np.ones((scale, scale, 1)))
    tmp = png[:-4] + ".tmp.png"
    plt.imsave(tmp, np.clip(rgb, 0, 1))
    os.replace(tmp, png)


def write_csv(path, rows):
    if not rows:
        return
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)


def savefig(fig, path):
    tmp = path[:-4] + ".tmp.png"
    fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    os.replace(tmp, path)


def chart_sweep(rows, path, res):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for m in sorted({r["method"] for r in rows}, key=list(METHODS).index):
        pts = sorted((r["factor"], r["l2_error"]) for r in rows if r["method"] == m)
        style = "-" if m.startswith("me-") else "--"
        ax.plot([p[0] for p in pts], [p[1] for p in pts], style, marker="o", label=m)
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("supersampling factor per axis (rays per pixel = factor²)")
    ax.set_ylabel("continuous L2 error vs closed form")
    ax.set_title(f"Too few rays: zone plate, {res}×{res}, error against factor")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    savefig(fig, path)


def chart_noise(noise, path):
    ms = [r["method"] for r in noise["methods"]]
    fig, ax = plt.subplots(figsize=(8, 4))
    x = range(len(ms))
    ax.bar([i - 0.27 for i in x], [r["gain"] for r in noise["methods"]], 0.27, label="measured")
    ax.bar([i for i in x], [r["discrete"] for r in noise["methods"]], 0.27, label="exact (discrete operator)")
    ax.bar([i + 0.27 for i in x], [r["theory"] for r in noise["methods"]], 0.27, label="continuous theory")
    ax.set_xticks(list(x))
    ax.set_xticklabels(ms, rotation=30, ha="right")
    ax.set_ylabel("output variance / (σ² / s²)")
    ax.set_yscale("log")
    ax.set_title("Noise gain per method and display (seeded white noise)")
    ax.legend()
    ax.grid(True, axis="y", alpha=0.3)
    savefig(fig, path)


def chart_hdr(rows, path):
    me = [r for r in rows if r["method"].startswith("me-")]
    labels = [f"{r['method']}\n{r['remedy']}" for r in me]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    a1.barh(range(len(me)), [max(r["negative_energy"], 1e-12) for r in me])
    a1.set_xscale("log")
    a1.set_yticks(range(len(me)))
    a1.set_yticklabels(labels, fontsize=7)
    a1.set_xlabel("negative energy (sum of squares of negative values)")
    a2.barh(range(len(me)), [r["display_rms"] for r in me], color="tab:orange")
    a2.set_yticks(range(len(me)))
    a2.set_yticklabels([])
    a2.set_xlabel("display RMS vs reference pixel averages")
    fig.suptitle("HDR scene: what each remedy saves (left) and costs (right)")
    savefig(fig, path)


def table(rows, cols, fmt=None):
    fmt = fmt or {}
    h = "<table><tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in cols) + "</tr>"
    for r in rows:
        h += "<tr>" + "".join(
            f"<td>{html.escape(fmt.get(c, lambda v: str(v))(r[c]))}</td>" for c in cols) + "</tr>"
    return h + "</table>"


def g(v):
    return f"{v:.4g}"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    p.add_argument("--out", default=os.path.join(ROOT, "out/report/stability"))
    p.add_argument("--quick", action="store_true", help="small sizes: about half a minute")
    a = p.parse_args()
    tools = Tools(os.path.abspath(a.build))
    if a.quick:
        res, factor, ref_factor, factors, noise_size = 48, 4, 8, [1, 2, 4], 64
    else:
        res, factor, ref_factor, factors, noise_size = 256, 4, 16, [1, 2, 3, 4, 6, 8], 192
    out = os.path.abspath(a.out)
    work = os.path.join(os.path.dirname(os.path.dirname(out)), "stability-render",
                        "quick" if a.quick else "full")
    os.makedirs(work, exist_ok=True)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    stage = tempfile.mkdtemp(prefix=".stability.", dir=os.path.dirname(out) or ".")
    try:
        t0 = time.monotonic()
        synthetic = json.loads(run([tools.sistability, "--size", str(noise_size)]))
        sweep = factor_sweep(tools, work, res, factors)
        edges = edges_study(tools, work, res, factor, ref_factor)
        hdr, hdr_src, _ = hdr_study(tools, work, res, factor, ref_factor)
        cross = {f"{a_} beats {b_}": crossover(sweep, a_, b_)
                 for a_, b_ in [("me-cubic", "conv-tent"), ("me-cubic", "mitchell"),
                                ("me-tent", "conv-tent"), ("me-tent", "mitchell"),
                                ("me-cubic", "box")]}
        results = {"sizes": {"output": res, "factor": factor, "reference_factor": ref_factor,
                             "sweep_factors": factors, "quick": a.quick},
                   "synthetic": synthetic, "sweep": sweep, "crossover": cross,
                   "edges": edges, "hdr": hdr, "seconds": round(time.monotonic() - t0, 1)}
        with open(os.path.join(stage, "stability.json"), "w") as f:
            json.dump(results, f, indent=1)
        write_csv(os.path.join(stage, "sweep.csv"), sweep)
        write_csv(os.path.join(stage, "edges.csv"), edges)
        write_csv(os.path.join(stage, "hdr.csv"), hdr)
        write_csv(os.path.join(stage, "noise.csv"), synthetic["noise"]["methods"])
        write_csv(os.path.join(stage, "step.csv"), synthetic["step"])
        write_csv(os.path.join(stage, "numerics.csv"), synthetic["numerics"])
        chart_sweep(sweep, os.path.join(stage, "sweep.png"), res)
        chart_noise(synthetic["noise"], os.path.join(stage, "noise.png"))
        chart_hdr(hdr, os.path.join(stage, "hdr.png"))
        # The HDR results, negatives in red.
        png = []
        for r in hdr:
            if r["method"] in ("conv-tent", "me-cubic"):
                name = "hdr-" + r["method"] + "-" + r["remedy"].replace(" ", "-") + ".png"
                viz_signed(os.path.join(work, r["image"]), os.path.join(stage, name),
                           scale=max(1, 512 // res))
                png.append((r["method"], r["remedy"], name))
        noise = synthetic["noise"]
        body = f"""<!doctype html><html><head><meta charset="utf-8"><title>Stability</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto}}table{{border-collapse:collapse;margin:1em 0}}
td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}}th{{background:#eee}}img{{max-width:100%}}
.row img{{width:250px;image-rendering:pixelated;margin:2px}}</style></head><body>
<h1>Stability where methods fail</h1>
<p>Made by <code>make stability{' QUICK=1' if a.quick else ''}</code> in {results['seconds']} s.
Output {res}×{res}, factor {factor}, reference factor {ref_factor}. Every number is in
<a href="stability.json">stability.json</a> and the CSV files beside this page.</p>
<h2>Too few rays</h2>
<p>Continuous L2 error against the zone plate's closed form (<code>scenes/zoneplate.pov</code>,
local frequency 0.7 of Nyquist at the edges), factors {', '.join(map(str, factors))}
(<a href="sweep.csv">sweep.csv</a>). The 2x2 displays sample the same f_app as their centred twins, so they
share their error; a conventional method's f_app is sum p[n] FILTER(x - x_n). Smallest factor from which the first method's error stays below the second's
(none: it never does in this range):</p>
{table([{'comparison': k, 'from factor': v if v else 'none'} for k, v in cross.items()], ['comparison', 'from factor'])}
<img src="sweep.png" alt="error against factor">
<h2>Noise</h2>
<p>Seeded white noise (σ = {noise['sigma']}) on the samples of a flat {noise['size']}×{noise['size']} image at factor
{noise['factor']}; gain = output variance / (σ²/s²), the variance of a pixel's box average. Theory: docs/design.md
section 6 (min-error: (1/π)∫|D(ω)|²/A(ω)dω per axis for display transfer D; conventional: s·Σw²/(Σw)² per
axis), which models the sampling as continuous; exact: the gain of the discrete operator the code applies,
s² times the sum over the s² sample phases of each impulse response's squares; sd: the measurement's standard
deviation, from the outputs' correlation. The hexagonal rows (density 1, centred display) are measured on 16 noise
images of a 32×32 frame inside a 4-pixel border, their exact gain from the operator's acquisition weights,
prefilter and resampling weights (hex_noise_gain); their pixels are not lattice points, and the continuous
theory is the density: white noise projected onto D basis functions per unit area keeps D times its variance
per unit area (<a href="noise.csv">noise.csv</a>).</p>
{table(noise['methods'], ['method', 'gain', 'discrete', 'measurement_sd', 'theory'], {'gain': g, 'discrete': g, 'measurement_sd': g, 'theory': g})}
<img src="noise.png" alt="noise gain">
<h2>Edges</h2>
<p>Step response of a unit edge (exact for min-error; measured at factor 16 for the conventional filters)
(<a href="step.csv">step.csv</a>):</p>
{table(synthetic['step'], ['method', 'overshoot', 'undershoot'], {'overshoot': g, 'undershoot': g})}
<p>The edges scene (values 0 and 1): overshoot beyond the local input range (the samples under the
pixel and its 8 neighbours), and the continuous L2 error against a factor-{ref_factor} render
(<a href="edges.csv">edges.csv</a>):</p>
{table(edges, ['method', 'max_overshoot', 'max_undershoot', 'pixels_out_of_range', 'l2_error'],
       {'max_overshoot': g, 'max_undershoot': g, 'l2_error': g})}
<h2>HDR and the remedies</h2>
<p>The hdr scene (emitters of 50 and 1000 on a dark room). Negative pixels and their energy (sum of
squares), the output range, and what the remedy costs: RMS of the displayed image against the reference
render's pixel averages (factor {ref_factor}) (<a href="hdr.csv">hdr.csv</a>). Clamps act on the displayed
samples only; highlight compression projects log-compressed samples and expands the result.</p>
{table(hdr, ['method', 'remedy', 'negative_pixels', 'negative_energy', 'min', 'max', 'pixels_out_of_range', 'display_rms'],
       {'negative_energy': g, 'min': g, 'max': g, 'display_rms': g})}
<img src="hdr.png" alt="remedies">
<p>Below: luminance tone-mapped as x/(1+x) in grey, negative values in red (full red at -0.05 and below).</p>
<div class="row">{''.join(f'<figure style="display:inline-block"><img src="{n}" alt="{m} {r}"><figcaption>{m}, {r}</figcaption></figure>' for m, r, n in png)}</div>
<h2>Numerics</h2>
<p>Prefilter on zero-mean random inputs of 256×256 for every degree: condition numbers 1/A(π) per axis and
in 2-D; the error of prefiltering the input rounded to float against double, relative to the largest
coefficient, and in units of float rounding 2<sup>-24</sup>; FFT against the recursive form
(<a href="numerics.csv">numerics.csv</a>).</p>
{table(synthetic['numerics'], ['degree', 'condition_1d', 'condition_2d', 'float_input_rel_error', 'float_amplification', 'fft_vs_recursive_rel'],
       {k: g for k in ['condition_1d', 'condition_2d', 'float_input_rel_error', 'float_amplification', 'fft_vs_recursive_rel']})}
</body></html>"""
        with open(os.path.join(stage, "index.html"), "w") as f:
            f.write(body)
        if os.path.isdir(out):
            shutil.rmtree(out)
        os.replace(stage, out)
        stage = None
        print(f"stability: {out}/index.html ({results['seconds']} s)")
    finally:
        if stage and os.path.isdir(stage):
            shutil.rmtree(stage)


if __name__ == "__main__":
    main()
