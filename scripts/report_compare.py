"""report_compare.py: the report of make compare (called by scripts/compare.py).

build(REPORT, WORK, META, ROWS) writes these files of REPORT (made in a
temporary folder inside it, then renamed into place one by one, index.html
last; other files of REPORT are left alone):
  index.html          charts, tables, images side by side, enlarged crops and
                      difference images; relative links only, no network
  results.json        META, every row, the derived tables and the findings
  results.csv         one row per (scene, factor, method) and per baseline
  main.csv            continuous L2 error per method and scene at equal rays
  hp.csv              high-pass shares beside the seed's table
  equal-rays.csv      best min-error against best conventional, per factor
  baseline.csv        POV-Ray's antialiasing against the cheapest method that
                      matches it
  README-results.md   the findings' text for docs/studies.md (make docs)
  compare/charts/*.png, compare/img/SCENE/*.png   (swapped in as one folder)
"""
import csv
import html
import io
import json
import math
import os
import shutil
import tempfile

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import siproject  # noqa: E402
from PIL import Image, ImageDraw  # noqa: E402

from atomic import current_umask  # noqa: E402

# docs/design.md section 4: the seed's high-pass shares (%), cutoff unpublished.
SEED_HP = {"box": 16.56, "conv-tent": 15.19, "me-tent": 19.18, "mitchell": 15.50,
           "me-cubic": 17.41, "me-tent-2x2": 15.97, "me-cubic-2x2": 16.34}
SEED_LABEL = {"box": "box", "conv-tent": "conv. tent", "me-tent": "min-error tent",
              "mitchell": "Mitchell", "me-cubic": "min-error cubic",
              "me-tent-2x2": "min-error tent AA", "me-cubic-2x2": "min-error cubic AA"}
LDR_SCENES = ("checker", "objects", "edges", "zoneplate")
STYLE = {
    "box": dict(color="0.45", marker="s"),
    "conv-tent": dict(color="tab:blue", marker="o"),
    "mitchell": dict(color="tab:green", marker="^"),
    "me-tent": dict(color="tab:orange", marker="o"),
    "me-cubic": dict(color="tab:red", marker="D"),
    "me-tent-2x2": dict(color="tab:orange", marker="o", linestyle="--", mfc="white"),
    "me-cubic-2x2": dict(color="tab:red", marker="D", linestyle="--", mfc="white"),
}
AA_STYLE = {"1": dict(color="black", marker="x", linestyle=":"),
            "2": dict(color="tab:purple", marker="*", linestyle=":", markersize=9)}
ASSETS = "compare"  # the report's charts and images: REPORT/compare/{charts,img}
DIFF_RANGE = 0.25  # signed difference images: -DIFF_RANGE .. +DIFF_RANGE (linear radiance)


# ---- small helpers -------------------------------------------------------------------

def fmt(x, digits=4):
    if x is None:
        return "n/a"
    if isinstance(x, int):
        return str(x)
    if x == 0:
        return "0"
    if abs(x) >= 1000 or abs(x) < 1e-3:
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}"


def pct(x):
    return "n/a" if x is None else f"{100 * x:.2f}"


def esc(s):
    return html.escape(str(s), quote=True)


CONVENTIONAL_ONLY = ("mitchell", "gaussian", "catmull-rom", "lanczos3")


def is_conventional(meta, m):
    """siproject's rule: --method conventional, or a conventional-only filter
    named alone; anything else is min-error (its default)."""
    words = meta["method_options"].get(m, "").replace("=", " ").split()
    method = words[words.index("--method") + 1] if "--method" in words[:-1] else None
    generator = words[words.index("--generator") + 1] if "--generator" in words[:-1] else None
    if method is not None:
        return method == "conventional"
    return generator in CONVENTIONAL_ONLY


def is_min_error(meta, m):
    return m in meta["method_options"] and not is_conventional(meta, m)


def is_centred(meta, m):
    return m not in meta["shares_f_app"]


def hpkey(c):
    return "hp_" + format(c, "g")


def rows_of(rows, **kw):
    return [r for r in rows if all(r.get(k) == v for k, v in kw.items())]


def one(rows, **kw):
    found = rows_of(rows, **kw)
    return found[0] if found else None


def finite(x):
    return isinstance(x, (int, float)) and math.isfinite(x)


def geomean(xs):
    xs = [x for x in xs if finite(x) and x > 0]
    return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else None


# ---- images -------------------------------------------------------------------------

def read_exr(path):
    """The first three channels (grey repeated) as float64, read by the module."""
    a = siproject.read_image(path).astype(np.float64)
    return a[..., :3] if a.shape[2] >= 3 else np.repeat(a[..., :1], 3, axis=-1)


def luminance(a):
    return siproject.luminance(a[..., :3])


def srgb8(a):
    return siproject.srgb8(a)


def upscale(img8, k):
    return img8 if k == 1 else np.repeat(np.repeat(img8, k, axis=0), k, axis=1)


def diff_rgb(d):
    cmap = plt.get_cmap("RdBu_r")
    t = np.clip(d / DIFF_RANGE, -1, 1) * 0.5 + 0.5
    return np.round(255 * cmap(t)[..., :3]).astype(np.uint8)


def save_png(path, img8):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    Image.fromarray(img8).save(path, optimize=True)


def pick_crops(stack, size, border, count=2):
    """Top-left corners of COUNT SIZE x SIZE windows (inside the border, each
    at least 2 SIZE from the others) where the images of STACK disagree most (per-pixel standard
    deviation across them, sRGB-encoded luminance, summed over the window)."""
    enc = np.stack([srgb8(np.repeat(luminance(a)[..., None], 3, axis=-1))[..., 0] / 255.0 for a in stack])
    score = enc.std(axis=0)
    h, w = score.shape
    s = np.zeros((h + 1, w + 1))
    s[1:, 1:] = score.cumsum(0).cumsum(1)
    lo = border
    hi_y, hi_x = h - border - size, w - border - size
    if hi_y < lo or hi_x < lo:
        lo, hi_y, hi_x = 0, max(0, h - size), max(0, w - size)
    ys = np.arange(lo, hi_y + 1)
    xs = np.arange(lo, hi_x + 1)
    win = (s[ys[:, None] + size, xs[None, :] + size] - s[ys[:, None], xs[None, :] + size]
           - s[ys[:, None] + size, xs[None, :]] + s[ys[:, None], xs[None, :]])
    picks = []
    win = win.copy()
    for _ in range(count):
        j, i = np.unravel_index(np.argmax(win), win.shape)
        if not np.isfinite(win[j, i]):
            break
        y, x = int(ys[j]), int(xs[i])
        picks.append((x, y))
        # the next window at least two window sizes away (another region of the image)
        yy0, yy1 = max(0, j - 2 * size + 1), min(win.shape[0], j + 2 * size)
        xx0, xx1 = max(0, i - 2 * size + 1), min(win.shape[1], i + 2 * size)
        win[yy0:yy1, xx0:xx1] = -np.inf
    return picks


# ---- derived tables -----------------------------------------------------------------

def derive(meta, rows):
    """Tables and findings from the rows (all numbers, no formatting)."""
    scenes, methods, cutoffs = meta["scenes"], meta["methods"], meta["cutoffs"]
    fmax, fshow = max(meta["factors"]), meta["show_factor"]
    ldr = [s for s in scenes if s in LDR_SCENES]
    out = {"max_factor": fmax, "ldr_scenes": ldr}

    # Continuous L2 per method and scene at fshow and fmax, plus baselines.
    main = []
    for f in sorted({fshow, fmax}):
        for m in methods:
            e = {"factor": f, "method": m, "rays_per_pixel": f * f}
            for s in scenes:
                r = one(rows, scene=s, method=m, factor=f)
                e[s] = r["l2"] if r else None
                e[s + "_time_s"] = r["total_s"] if r else None
            main.append(e)
    out["main"] = main

    # High-pass table: per scene at fmax, mean over the LDR scenes.
    hp = []
    for m in methods:
        e = {"method": m, "seed_percent": SEED_HP.get(m)}
        for c in cutoffs:
            vals = []
            for s in scenes:
                r = one(rows, scene=s, method=m, factor=fmax)
                v = r[hpkey(c)] if r else None
                e[f"{s}@{c:g}"] = v
                if s in ldr and v is not None:
                    vals.append(v)
            e[f"ldr_mean@{c:g}"] = sum(vals) / len(vals) if vals else None
        hp.append(e)
    out["hp"] = hp

    # Ordering checks against the seed's findings.
    checks = []

    def order_check(where, values):
        """VALUES: {method: share}. The seed's three findings, and the rank correlation."""
        have = {m: v for m, v in values.items() if v is not None}
        res = {"where": where}
        if "me-tent" in have:
            res["me_tent_highest"] = all(have["me-tent"] >= v for v in have.values())
        conv = [m for m in have if is_conventional(meta, m)]
        if conv:
            lowest = min(have, key=have.get)
            res["lowest"] = lowest
            res["conventional_lowest"] = lowest in conv
        between = []
        for aa, centred in (("me-tent-2x2", "me-tent"), ("me-cubic-2x2", "me-cubic")):
            if aa in have and centred in have and "conv-tent" in have and "mitchell" in have:
                between.append(max(have["conv-tent"], have["mitchell"]) < have[aa] < have[centred])
        if between:
            res["aa_between"] = all(between)
        common = [m for m in have if m in SEED_HP]
        if len(common) >= 3:
            ours = rank([have[m] for m in common])
            seed = rank([SEED_HP[m] for m in common])
            n = len(common)
            res["spearman"] = 1 - 6 * sum((a - b) ** 2 for a, b in zip(ours, seed)) / (n * (n * n - 1))
            res["order"] = sorted(common, key=lambda m: -have[m])
        return res

    for c in cutoffs:
        if ldr:
            checks.append({"cutoff": c, **order_check("mean of " + ", ".join(ldr),
                                                      {e["method"]: e[f"ldr_mean@{c:g}"] for e in hp})})
        for s in scenes:
            checks.append({"cutoff": c, **order_check(s, {e["method"]: e[f"{s}@{c:g}"] for e in hp})})
    out["hp_checks"] = checks

    # Equal rays: best min-error against best conventional (f_app, continuous L2).
    eq = []
    for s in scenes:
        for f in meta["factors"]:
            me = [r for r in rows_of(rows, scene=s, factor=f) if is_min_error(meta, r["method"])
                  and is_centred(meta, r["method"]) and r["l2"] is not None]
            cv = [r for r in rows_of(rows, scene=s, factor=f) if is_conventional(meta, r["method"])
                  and r["l2"] is not None]
            if not me or not cv:
                continue
            bm = min(me, key=lambda r: r["l2"])
            bc = min(cv, key=lambda r: r["l2"])
            eq.append({"scene": s, "factor": f, "rays_per_pixel": f * f, "best_min_error": bm["method"],
                       "min_error_l2": bm["l2"], "best_conventional": bc["method"],
                       "conventional_l2": bc["l2"], "ratio": bm["l2"] / bc["l2"] if bc["l2"] else None,
                       "winner": "min-error" if bm["l2"] < bc["l2"] else "conventional"})
    out["equal_rays"] = eq
    crossover = {}
    for s in scenes:
        es = sorted([e for e in eq if e["scene"] == s], key=lambda e: e["factor"])
        k = None
        for i in range(len(es)):
            if all(x["winner"] == "min-error" for x in es[i:]):
                k = es[i]["factor"]
                break
        crossover[s] = k
    out["crossover"] = crossover

    # Baselines: the cheapest method/factor reaching the baseline's error.
    base = []
    for s in scenes:
        ours = [r for r in rows_of(rows, scene=s, kind="method")]
        for b in rows_of(rows, scene=s, kind="pov-aa"):
            e = {"scene": s, "baseline": b["method"], "label": b.get("label"),
                 "rays_per_pixel": b["rays_per_pixel"], "time_s": b["total_s"], "l2": b["l2"], "rms": b["rms"]}
            for metric in ("l2", "rms"):
                ok = [r for r in ours if r[metric] is not None and b[metric] is not None and r[metric] <= b[metric]]
                if ok:
                    best = min(ok, key=lambda r: r["total_s"])
                    e[f"cheapest_{metric}_method"] = best["method"]
                    e[f"cheapest_{metric}_factor"] = best["factor"]
                    e[f"cheapest_{metric}_time_s"] = best["total_s"]
                    e[f"cheapest_{metric}_value"] = best[metric]
                    e[f"time_ratio_{metric}"] = best["total_s"] / b["total_s"] if b["total_s"] else None
                else:
                    e[f"cheapest_{metric}_method"] = None
            base.append(e)
    out["baselines"] = base

    # Overshoot at the shown factor.
    ov = []
    for s in scenes:
        for m in methods:
            r = one(rows, scene=s, method=m, factor=fshow)
            if r:
                ov.append({"scene": s, "method": m, "factor": fshow, "max_overshoot": r["max_overshoot"],
                           "max_undershoot": r["max_undershoot"], "negative_pixels": r["negative_pixels"],
                           "pixels_out_of_range": r["pixels_out_of_range"], "pixels": r["ov_pixels"]})
    out["overshoot"] = ov

    # Zone plate: the closed-form error against the error measured on the reference render.
    zp = [{"method": r["method"], "factor": r["factor"], "l2_closed_form": r["l2"],
           "l2_reference_render": r.get("l2_against_render")}
          for r in rows_of(rows, scene="zoneplate", factor=fshow) if r.get("l2_against_render") is not None
          and is_centred(meta, r["method"])]
    out["zoneplate_check"] = zp

    # POV-Ray's fixed cost: wall time minus trace time of the factor-1 renders.
    fixed = []
    for s in scenes:
        r = one(rows, scene=s, method=methods[0], factor=min(meta["factors"]))
        if r and r.get("render_trace_s") is not None:
            fixed.append(r["render_s"] - r["render_trace_s"])
    out["povray_fixed_s"] = sum(fixed) / len(fixed) if fixed else None
    out["floors"] = floors(meta, rows, out)
    out["findings"] = findings(meta, rows, out)
    return out


def rank(values):
    order = sorted(range(len(values)), key=lambda i: values[i])
    r = [0.0] * len(values)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and values[order[j + 1]] == values[order[i]]:
            j += 1
        for k in range(i, j + 1):
            r[order[k]] = (i + j) / 2 + 1
        i = j + 1
    return r


def floors(meta, rows, d):
    """Per scene: POV-Ray's deepest antialiasing as a continuous image (box f_app) against the
    box at the largest factor, and the first (factor, method) of ours below it."""
    fmax = d["max_factor"]
    out = []
    for s in meta["scenes"]:
        bs = sorted([b for b in d["baselines"] if b["scene"] == s and b["l2"] is not None],
                    key=lambda b: -(b["rays_per_pixel"] or 0))
        box = one(rows, scene=s, method="box", factor=fmax)
        if not bs or not box or box["l2"] is None:
            continue
        below = [r for r in rows_of(rows, scene=s, kind="method") if r["method"] != "box"
                 and is_centred(meta, r["method"]) and r["l2"] is not None and r["l2"] < bs[0]["l2"]]
        first = min(below, key=lambda r: (r["factor"], r["l2"])) if below else None
        out.append({"scene": s, "baseline": bs[0]["label"], "rays_per_pixel": bs[0]["rays_per_pixel"],
                    "l2": bs[0]["l2"], "box_l2": box["l2"],
                    "first_method": first["method"] if first else None,
                    "first_factor": first["factor"] if first else None,
                    "first_l2": first["l2"] if first else None})
    return out


def findings(meta, rows, d):
    """A few sentences of conclusions, every number computed from the rows; the
    per-scene numbers are in the tables."""
    out = []
    fmax = d["max_factor"]
    scenes = meta["scenes"]
    # 1. Accuracy at equal rays.
    cross = d["crossover"]
    at_max = {e["scene"]: e["ratio"] for e in d["equal_rays"] if e["factor"] == fmax and e["ratio"] is not None}
    if at_max:
        first = min(meta["factors"])
        winners = [s for s in scenes if cross.get(s) is not None]
        froms = ", ".join(f"{s} from factor {cross[s]:g}" if cross[s] != first else f"{s} at every factor"
                          for s in winners)
        lo, hi = min(at_max.values()), max(at_max.values())
        out.append(f"At equal rays min-error's f_app has the lower continuous L2 error than the best conventional "
                   f"filter in {len(winners)} of {len(scenes)} scenes from some factor on ({froms}); at factor "
                   f"{fmax:g} its error is {lo:.2f} to {hi:.2f} times the conventional one's "
                   f"(lowest: {min(at_max, key=at_max.get)}).")
    # 2. The seed's high-pass order.
    parts = []
    for c in meta["cutoffs"]:
        agg = next((x for x in d["hp_checks"] if x["cutoff"] == c and x["where"].startswith("mean")), None)
        per = [x for x in d["hp_checks"] if x["cutoff"] == c and not x["where"].startswith("mean")]
        if agg and "spearman" in agg:
            parts.append(f"above {c:g} cycles/pixel min-error tent is highest in "
                         f"{sum(1 for x in per if x.get('me_tent_highest'))} of {len(per)} scenes, a conventional "
                         f"filter lowest in {sum(1 for x in per if x.get('conventional_lowest'))}, the 2x2 displays "
                         f"between in {sum(1 for x in per if x.get('aa_between'))} (rank correlation of the mean "
                         f"with the seed's table {agg['spearman']:.2f})")
    if parts:
        out.append("The high-pass shares keep the seed's order: " + "; ".join(parts) + ".")
    # 3. The displayed image against pixel averages.
    low = {}
    for s in scenes:
        rs = [r for r in rows_of(rows, scene=s, factor=fmax) if r["rms"] is not None]
        if rs:
            low.setdefault(min(rs, key=lambda r: r["rms"])["method"], []).append(s)
    if low:
        top = max(low, key=lambda m: len(low[m]))
        out.append(f"Against the reference's pixel averages (display RMS, factor {fmax:g}) {top} is closest in "
                   f"{len(low[top])} of {len(scenes)} scenes: that measure is the box's own target and ranks the "
                   f"sharper centred displays low even where their f_app is the most accurate.")
    # 4. POV-Ray's antialiasing.
    bs = d["baselines"]
    if bs:
        ratios = [b["time_ratio_rms"] for b in bs if b.get("cheapest_rms_method") and b.get("time_ratio_rms")]
        none = [b for b in bs if not b.get("cheapest_rms_method")]
        fl = floors(meta, rows, d)
        passed1 = [x for x in fl if x["first_factor"] == min(meta["factors"])]
        text = (f"POV-Ray's antialiasing: for {len(ratios)} of {len(bs)} (scene, setting) pairs a (method, factor) "
                f"here gives a displayed image as close to the reference")
        if ratios:
            text += (f" in {min(ratios):.2f} to {max(ratios):.2f} times POV-Ray's time (median "
                     f"{float(np.median(ratios)):.2f})")
        if none:
            text += f"; for {len(none)} none measured is as close ({', '.join(sorted({b['label'] for b in none}))})"
        text += "."
        if fl:
            text += (f" As continuous images its pixels are piecewise constant, so their L2 error stops at the "
                     f"box's floor, and a smoother f_app at factor {min(meta['factors']):g} is already below it in "
                     f"{len(passed1)} of {len(fl)} scenes.")
        out.append(text)
    # 5. Cost.
    shares = [r["project_s"] / r["render_s"] for r in rows
              if r["kind"] == "method" and r["factor"] == fmax and r["render_s"]]
    if shares:
        t = f"The projection costs {100 * float(np.mean(shares)):.1f} % of the render's time at factor {fmax:g} (mean over methods and scenes)"
        if d["povray_fixed_s"] is not None:
            t += f"; POV-Ray's start-up and parse, about {d['povray_fixed_s']:.2f} s a render, are in every time"
        out.append(t + ".")
    # 6. The reference.
    if d["zoneplate_check"]:
        worst = max(abs(z["l2_reference_render"] - z["l2_closed_form"]) / z["l2_closed_form"]
                    for z in d["zoneplate_check"] if z["l2_closed_form"])
        out.append(f"The reference render is an adequate truth: on the zone plate the error against it differs "
                   f"from the closed form's by at most {100 * worst:.2g} % (factor {meta['show_factor']:g}, every "
                   f"centred method).")
    return out


def yes(b):
    return "n/a" if b is None else ("yes" if b else "no")


# ---- charts ---------------------------------------------------------------------------

def aa_series(rows, scene):
    out = {}
    for r in rows_of(rows, scene=scene, kind="pov-aa"):
        am = r["method"].split("-")[1][2]  # pov-am1-r2 -> "1"
        out.setdefault(am, []).append(r)
    for am in out:
        out[am].sort(key=lambda r: r["rays_per_pixel"] or 0)
    return out


def plot_panel(ax, meta, rows, scene, xkey, ykey, centred_only):
    for m in meta["methods"]:
        if centred_only and not is_centred(meta, m):
            continue
        rs = sorted(rows_of(rows, scene=scene, method=m), key=lambda r: r["factor"])
        pts = [(r[xkey] if xkey != "factor" else r["factor"], r[ykey]) for r in rs
               if r[ykey] is not None and r[ykey] > 0]
        if pts:
            ax.plot(*zip(*pts), label=m, linewidth=1.4, markersize=5, **STYLE.get(m, {}))
    for am, rs in sorted(aa_series(rows, scene).items()):
        if xkey == "factor":
            pts = [(math.sqrt(r["rays_per_pixel"]), r[ykey]) for r in rs
                   if r["rays_per_pixel"] and r[ykey] is not None and r[ykey] > 0]
        else:
            pts = [(r[xkey], r[ykey]) for r in rs if r[ykey] is not None and r[ykey] > 0]
        if pts:
            ax.plot(*zip(*pts), label=f"POV-Ray +AM{am}", linewidth=1.2, **AA_STYLE.get(am, {}))
    ax.set_xscale("log")
    ax.set_yscale("log")
    nice_log_ticks(ax.xaxis, [p for line in ax.get_lines() for p in line.get_xdata()])
    nice_log_ticks(ax.yaxis, [p for line in ax.get_lines() for p in line.get_ydata()])
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(scene)


def nice_log_ticks(axis, values):
    """Readable ticks on a log axis of any span: 1-2-5 steps, finer when the
    data cover less than a decade; plain %g labels, no minor labels."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator, NullFormatter
    vals = [v for v in values if finite(v) and v > 0]
    if not vals:
        return
    lo, hi = min(vals), max(vals)
    inside = []
    for mantissas in ((1, 10), (1, 3), (1, 2, 5), (1, 1.5, 2, 3, 5, 7), (1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 7, 8, 9)):
        ticks = [m * 10 ** e for e in range(math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 1)
                 for m in mantissas]
        inside = sorted({float(f"{t:.6g}") for t in ticks if lo / 1.03 <= t <= hi * 1.03})
        if len(inside) >= 3:
            break
    if len(inside) < 3:  # less than about a decade: evenly spaced round values
        inside = [t for t in MaxNLocator(nbins=4).tick_values(lo, hi) if t > 0 and lo / 1.1 <= t <= hi * 1.1]
    axis.set_major_locator(FixedLocator(inside))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.3g}"))
    axis.set_minor_formatter(NullFormatter())


def chart_grid(path, meta, rows, ykey, ylabel, xkey, xlabel, centred_only, title):
    scenes = meta["scenes"]
    n = len(scenes)
    cols = min(3, n)
    nrows = math.ceil(n / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(4.6 * cols, 3.6 * nrows + 0.6), squeeze=False)
    for i, s in enumerate(scenes):
        ax = axes[i // cols][i % cols]
        plot_panel(ax, meta, rows, s, xkey, ykey, centred_only)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        if xkey == "factor":
            ax.set_xticks(meta["factors"])
            ax.set_xticklabels([f"{f:g}" for f in meta["factors"]])
            ax.minorticks_off()
    for j in range(n, nrows * cols):
        axes[j // cols][j % cols].axis("off")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 5), fontsize=9, frameon=False)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout(rect=(0, 0.06 + 0.02 * (nrows == 1), 1, 0.96))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def chart_scene(path, meta, rows, scene):
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    plot_panel(axes[0], meta, rows, scene, "total_s", "l2", True)
    axes[0].set_xlabel("total time, render + projection (s)")
    axes[0].set_ylabel("continuous L2 error of f_app")
    axes[0].set_title(f"{scene}: continuous L2 error against time")
    plot_panel(axes[1], meta, rows, scene, "total_s", "rms", False)
    axes[1].set_xlabel("total time, render + projection (s)")
    axes[1].set_ylabel("RMS of the display against the reference")
    axes[1].set_title(f"{scene}: displayed image against time")
    plot_panel(axes[2], meta, rows, scene, "factor", "l2", True)
    axes[2].set_xlabel("factor s (s^2 rays per pixel; POV-Ray: sqrt of its rays)")
    axes[2].set_ylabel("continuous L2 error of f_app")
    axes[2].set_title(f"{scene}: continuous L2 error against factor")
    axes[2].set_xticks(meta["factors"])
    axes[2].set_xticklabels([f"{f:g}" for f in meta["factors"]])
    axes[2].minorticks_off()
    handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 9), fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    fig.savefig(path, dpi=80)
    plt.close(fig)


def chart_hp(path, meta, d):
    methods = [e["method"] for e in d["hp"]]
    x = np.arange(len(methods))
    series = [("seed (docs/design.md 4)", [e["seed_percent"] for e in d["hp"]], "0.75")]
    for i, c in enumerate(meta["cutoffs"]):
        series.append((f"ours, cutoff {c:g} c/px", [None if e[f"ldr_mean@{c:g}"] is None
                                                    else 100 * e[f"ldr_mean@{c:g}"] for e in d["hp"]],
                       ["tab:blue", "tab:cyan", "tab:olive"][i % 3]))
    width = 0.8 / len(series)
    fig, ax = plt.subplots(figsize=(10, 4))
    for i, (label, vals, color) in enumerate(series):
        v = [np.nan if y is None else y for y in vals]
        ax.bar(x + (i - (len(series) - 1) / 2) * width, v, width, label=label, color=color)
    ax.set_xticks(x)
    ax.set_xticklabels(methods)
    ax.set_ylabel("high-pass energy share (%)")
    ax.set_title(f"High-pass share of the displayed image, factor {d['max_factor']:g}, "
                 f"mean of {', '.join(d['ldr_scenes']) or 'no LDR scene'}")
    ax.legend(fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def chart_diff_scale(path):
    fig, ax = plt.subplots(figsize=(5, 0.9))
    grad = np.linspace(-DIFF_RANGE, DIFF_RANGE, 256)[None, :]
    ax.imshow(diff_rgb(grad), aspect="auto", extent=(-DIFF_RANGE, DIFF_RANGE, 0, 1))
    ax.set_yticks([])
    ax.set_xticks([-DIFF_RANGE, -DIFF_RANGE / 2, 0, DIFF_RANGE / 2, DIFF_RANGE])
    ax.set_xlabel("method minus reference, luminance (linear); clipped beyond the ends", fontsize=8)
    ax.tick_params(labelsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


# ---- image cards ---------------------------------------------------------------------

def scene_images(tmp, work, meta, rows, scene):
    """PNGs of the reference display, every method at the shown factor and the
    baselines nearest to its rays; returns (cards, crops, up, crop_up)."""
    fshow = meta["show_factor"]
    refdisp = os.path.join(work, meta["references"][scene]["display"])
    ref = read_exr(refdisp)
    cards = [{"name": "reference", "title": f"reference: pixel averages of factor {meta['ref_factor']:g}",
              "img": ref, "row": None}]
    for m in meta["methods"]:
        r = one(rows, scene=scene, method=m, factor=fshow)
        if r:
            cards.append({"name": m, "title": f"{m}, factor {fshow:g}", "img": read_exr(os.path.join(work, r["image"])),
                          "row": r})
    for am, rs in sorted(aa_series(rows, scene).items()):
        target = fshow * fshow
        r = min(rs, key=lambda r: abs(math.log((r["rays_per_pixel"] or 1) / target)))
        cards.append({"name": r["method"], "title": f"{r.get('label')} ({r['rays_per_pixel']:.1f} rays/px)",
                      "img": read_exr(os.path.join(work, r["image"])), "row": r})
    h, w = ref.shape[:2]
    up = max(1, round(256 / max(w, h)))
    csize = max(8, min(w, h) // 6)
    crop_up = max(1, 256 // csize)
    crops = pick_crops([c["img"] for c in cards[1:]], csize, meta["border"], 2)
    d = os.path.join(tmp, ASSETS, "img", scene)
    ref_lum = luminance(ref)
    for c in cards:
        base = f"{ASSETS}/img/{scene}/{c['name']}"
        full = srgb8(c["img"])
        if c["name"] == "reference":
            full_up = upscale(full, up)
            im = Image.fromarray(full_up)
            draw = ImageDraw.Draw(im)
            for k, (x, y) in enumerate(crops):
                col = (255, 200, 0) if k == 0 else (0, 220, 255)
                draw.rectangle([x * up - 1, y * up - 1, (x + csize) * up, (y + csize) * up], outline=col, width=2)
            os.makedirs(d, exist_ok=True)
            im.save(os.path.join(tmp, base + ".png"), optimize=True)
        else:
            save_png(os.path.join(tmp, base + ".png"), upscale(full, up))
        c["full"] = base + ".png"
        c["crops"] = []
        for k, (x, y) in enumerate(crops):
            p = f"{base}-crop{k + 1}.png"
            save_png(os.path.join(tmp, p), upscale(full[y:y + csize, x:x + csize], crop_up))
            c["crops"].append(p)
        if c["name"] != "reference":
            diff = luminance(c["img"]) - ref_lum
            dimg = diff_rgb(diff)
            save_png(os.path.join(tmp, base + "-diff.png"), upscale(dimg, up))
            c["diff"] = base + "-diff.png"
            c["diff_crops"] = []
            for k, (x, y) in enumerate(crops):
                p = f"{base}-diff-crop{k + 1}.png"
                save_png(os.path.join(tmp, p), upscale(dimg[y:y + csize, x:x + csize], crop_up))
                c["diff_crops"].append(p)
            c["max_abs_diff"] = float(np.abs(diff).max())
    return cards, crops, up, csize, crop_up


# ---- CSV ---------------------------------------------------------------------------

def csv_text(header, rows):
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for r in rows:
        w.writerow(["" if r.get(k) is None else (repr(r[k]) if isinstance(r[k], float) else r[k]) for k in header])
    return buf.getvalue()


# ---- HTML ---------------------------------------------------------------------------

CSS = """
body { font-family: sans-serif; margin: 1.2em 2em; max-width: 1500px; color: #222; }
h1 { font-size: 1.5em; } h2 { margin-top: 1.6em; border-bottom: 1px solid #ccc; } h3 { margin-top: 1.2em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
th { background: #f0f0f0; } td.l, th.l { text-align: left; }
td.best { background: #d8f5d0; font-weight: bold; } td.worst { background: #fbe0dc; }
.cards { display: flex; flex-wrap: wrap; gap: 10px; }
.card { border: 1px solid #ddd; padding: 4px; width: 262px; font-size: 0.8em; }
.card img { display: block; margin: 2px 0; image-rendering: pixelated; }
.card .t { font-weight: bold; height: 2.4em; overflow: hidden; }
.note { color: #555; font-size: 0.9em; max-width: 75em; }
ul.findings li { margin: 0.35em 0; max-width: 80em; }
img.chart { max-width: 100%; }
code { background: #f4f4f4; padding: 0 3px; }
"""


def table_html(header, body, classes=None):
    out = ["<table><tr>" + "".join(f"<th class='{'l' if i == 0 else ''}'>{h}</th>" for i, h in enumerate(header))
           + "</tr>"]
    for i, row in enumerate(body):
        cls = (classes or {}).get(i, {})
        out.append("<tr>" + "".join(
            f"<td class='{('l ' if j == 0 else '') + cls.get(j, '')}'>{c}</td>" for j, c in enumerate(row)) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


def build_html(meta, rows, d, charts, scene_cards, files):
    m = meta
    H = []
    H.append("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
             f"<title>Comparison: accuracy against speed ({esc(m['label'])})</title><style>{CSS}</style></head><body>")
    H.append(f"<h1>Rendering in shift-invariant spaces: accuracy against speed</h1>")
    H.append(
        f"<p class='note'>Configuration <b>{esc(m['label'])}</b>: scenes {esc(', '.join(m['scenes']))}; output "
        f"{m['width']} x {m['height']}; factors {esc(' '.join(f'{f:g}' for f in m['factors']))} (POV-Ray renders "
        f"s x the output size per axis, antialiasing off, s<sup>2</sup> rays per pixel); reference: a render at "
        f"factor {m['ref_factor']:g} ({esc(', '.join(str(r['width']) + ' x ' + str(r['height']) for r in list(m['references'].values())[:1]))}), "
        f"for the zone plate its closed form (ZP_K = {m['zp_k']:g}, {m['zp_samples_per_pixel']} points per "
        f"pixel and axis). Border band left out of every error: {m['border']} output pixels. "
        f"{esc(m['povray'])}; {m['nproc']} cores; made {esc(m['date'])}.</p>")
    H.append("<p>Numbers: " + " &middot; ".join(f"<a href='{esc(f)}'>{esc(f)}</a>" for f in files
                                                 if f != "index.html") + "</p>")

    H.append("<h2 id='charts'>Error against time</h2>")
    H.append(f"<p class='note'>Log-log; one line per method, its points the factors "
             f"{esc(' '.join(f'{f:g}' for f in m['factors']))}; dotted: POV-Ray's antialiasing at its depths. "
             "Left: continuous L2 error of f_app (the 2x2 displays coincide with their centred method and are not "
             "drawn). Data: <a href='results.csv'>results.csv</a>.</p>")
    H.append(f"<img class='chart' src='{charts['time']}' alt='continuous L2 error against total time'>")
    H.append(f"<img class='chart' src='{charts['display_time']}' alt='display RMS against total time'>")
    H.append(f"<img class='chart' src='{charts['factor']}' alt='continuous L2 error against factor'>")

    # Main table.
    H.append("<h2 id='main'>Continuous L2 error at equal rays</h2>")
    H.append("<p class='note'>Per method (rows) and scene (columns): continuous L2 error of f_app; best of "
             "each column green, worst red; in brackets the total time (s). Data: <a href='main.csv'>main.csv</a>."
             "</p>")
    for f in sorted({m['show_factor'], d['max_factor']}):
        H.append(f"<h3>factor {f:g} ({f * f:g} rays per pixel)</h3>")
        body, classes = [], {}
        entries = [e for e in d["main"] if e["factor"] == f and is_centred(m, e["method"])]
        for i, e in enumerate(entries):
            body.append([esc(e["method"])] + [f"{fmt(e[s])} <small>({fmt(e[s + '_time_s'], 3)})</small>"
                                              for s in m["scenes"]])
        for j, s in enumerate(m["scenes"]):
            vals = [(i, e[s]) for i, e in enumerate(entries) if e[s] is not None]
            if vals:
                classes.setdefault(min(vals, key=lambda v: v[1])[0], {})[j + 1] = "best"
                classes.setdefault(max(vals, key=lambda v: v[1])[0], {})[j + 1] = "worst"
        H.append(table_html(["method"] + [esc(s) for s in m["scenes"]], body, classes))

    # High-pass table.
    H.append("<h2 id='highpass'>High-pass energy share beside the seed's table</h2>")
    cols = ["method", "seed (%)"] + [f"{s} &gt;{c:g}" for c in m["cutoffs"] for s in m["scenes"]] + \
           [f"LDR mean &gt;{c:g}" for c in m["cutoffs"]]
    body = []
    for e in d["hp"]:
        body.append([esc(e["method"]), fmt(e["seed_percent"])] +
                    [pct(e[f"{s}@{c:g}"]) for c in m["cutoffs"] for s in m["scenes"]] +
                    [pct(e[f"ldr_mean@{c:g}"]) for c in m["cutoffs"]])
    H.append(f"<p class='note'>Share (%) of the displayed luminance's DFT energy above the cutoff (cycles/pixel), "
             f"factor {d['max_factor']:g}; LDR mean over {esc(', '.join(d['ldr_scenes']))}. The seed's numbers "
             "(1000 x 1000, 256 rays per coefficient, cutoff and scene unpublished) are from docs/design.md section 4: "
             "compare the ordering, not the values. Data: <a href='hp.csv'>hp.csv</a>.</p>")
    H.append(table_html(cols, body))
    H.append(f"<img class='chart' src='{charts['hp']}' alt='high-pass shares beside the seed'>")

    H.append("<h2 id='findings'>Conclusions</h2><ul class='findings'>")
    for f in d["findings"]:
        H.append(f"<li>{esc(f)}</li>")
    H.append("</ul>")

    # The per-scene numbers.
    H.append("<h2 id='per-scene'>Per scene</h2>")
    csvs = {"Min-error against conventional at equal rays": "equal-rays.csv",
            "POV-Ray's antialiasing against the cheapest method as close": "baseline.csv"}
    for title, note, header, body in scene_tables(meta, rows, d):
        data = f" Data: <a href='{csvs[title]}'>{csvs[title]}</a>." if title in csvs else ""
        H.append(f"<h3>{esc(title)}</h3><p class='note'>{esc(note)}{data}</p>")
        H.append(table_html([esc(h) for h in header], [[esc(c) for c in r] for r in body]))
    H.append("<h3>High-pass order against the seed's findings</h3>")
    body = []
    for x in d["hp_checks"]:
        body.append([esc(x["where"]), f"{x['cutoff']:g}", yes(x.get("me_tent_highest")),
                     f"{yes(x.get('conventional_lowest'))} ({esc(x.get('lowest'))})", yes(x.get("aa_between")),
                     fmt(x.get("spearman"), 2), " &gt; ".join(esc(o) for o in x.get("order", []))])
    H.append(table_html(["where", "cutoff", "min-error tent highest", "conventional lowest",
                         "2x2 in between", "rank corr. with seed", "our order"], body))

    # Scenes.
    H.append("<h2 id='scenes'>Scenes</h2>")
    H.append(f"<p class='note'>Images at factor {m['show_factor']:g} (POV-Ray's antialiasing: the depth nearest "
             f"in rays), 8-bit sRGB, clamped to [0, 1]; enlarged by whole-pixel repetition (nearest neighbour). "
             f"Crops: the two windows (two window widths apart at least) where the images disagree most "
             f"(per-pixel spread across them), marked on "
             f"the reference (yellow 1, cyan 2). Difference images: luminance of the image minus that of the "
             f"reference display, linear units, red positive, blue negative, &plusmn;{DIFF_RANGE:g} at the ends "
             f"(clipped beyond):</p><img src='{charts['diff_scale']}' alt='colour scale of the difference images'>")
    for scene, (cards, crops, up, csize, crop_up) in scene_cards.items():
        H.append(f"<h3 id='scene-{esc(scene)}'>{esc(scene)}</h3>")
        H.append(f"<img class='chart' src='{charts['scene'][scene]}' alt='{esc(scene)}: error against time and factor'>")
        crop_txt = "; ".join(f"crop {k + 1}: x {x}..{x + csize - 1}, y {y}..{y + csize - 1}"
                             for k, (x, y) in enumerate(crops))
        H.append(f"<p class='note'>Full images x{up}; crops {csize} x {csize} output pixels x{crop_up} "
                 f"({crop_txt}).</p><div class='cards'>")
        for c in cards:
            r = c["row"]
            info = ""
            if r:
                info = (f"L2 {fmt(r['l2'])} &middot; RMS {fmt(r['rms'])} &middot; PSNR {fmt(r['psnr'], 3)} dB"
                        f"<br>hp " + " / ".join(f"{pct(r[hpkey(cc)])}" for cc in m["cutoffs"]) +
                        f" % &middot; {fmt(r['total_s'], 3)} s")
            H.append(f"<div class='card'><div class='t'>{esc(c['title'])}</div>")
            H.append(f"<img src='{c['full']}' alt='{esc(c['name'])}'>")
            for p in c["crops"]:
                H.append(f"<img src='{p}' alt='{esc(c['name'])} crop'>")
            if c.get("diff"):
                H.append(f"<img src='{c['diff']}' alt='{esc(c['name'])} difference'>")
                for p in c["diff_crops"]:
                    H.append(f"<img src='{p}' alt='{esc(c['name'])} difference crop'>")
            H.append(f"<div>{info}</div></div>")
        H.append("</div>")
        # Full table of the scene.
        H.append(f"<details><summary>every number of {esc(scene)}</summary>")
        body = []
        for r in sorted(rows_of(rows, scene=scene), key=lambda r: (r["kind"], r["factor"] or 0, r["method"])):
            body.append([esc(r.get("label") or r["method"]), "" if r["factor"] is None else f"{r['factor']:g}",
                         fmt(r["rays_per_pixel"], 3), fmt(r["render_s"], 3), fmt(r["project_s"], 3),
                         fmt(r["total_s"], 3), fmt(r["l2"]), fmt(r["rms"]), fmt(r["psnr"], 3)] +
                        [pct(r[hpkey(c)]) for c in m["cutoffs"]] +
                        [fmt(r["max_overshoot"], 3), fmt(r["max_undershoot"], 3), fmt(r["negative_pixels"])])
        H.append(table_html(["method", "factor", "rays/px", "render (s)", "project (s)", "total (s)", "L2",
                             "RMS", "PSNR"] + [f"hp &gt;{c:g} (%)" for c in m["cutoffs"]] +
                            ["over", "under", "neg. px"], body))
        H.append("</details>")
    H.append("<h2 id='measures'>How it is measured</h2>")
    H.append(
        "<p class='note'><b>Measures.</b> <i>Continuous L2 error</i>: RMS of f_app &minus; f over the reference "
        "grid (simetrics --coeffs --truth / --zoneplate), where f_app = sum c[n] phi(x &minus; x_n) for min-error "
        "and f_app = sum p[n] FILTER(x &minus; x_n) for the conventional filters (box: piecewise constant); the "
        "2x2 displays share f_app with their centred method (same coefficients), so they share its continuous "
        "error. POV-Ray's antialiased image is taken as piecewise constant (box f_app). <i>Display RMS / "
        "PSNR</i>: the displayed image against the reference's pixel averages (peak 1). <i>High-pass share</i>: "
        "DFT energy of the displayed luminance, mean removed, above the cutoff in cycles/pixel (whole image). "
        "<i>Overshoot</i>: how far the display leaves [min, max] of the input samples under each pixel and one "
        "pixel around it (the method's own render; for POV-Ray's antialiasing the reference render). "
        "<i>Time</i>: POV-Ray's wall time as scripts/render.sh records it (start-up and parse included; smallest of "
        f"{m['repeats']} runs for renders under {m['repeat_below_s']:g} s) plus the projection's (the render read, "
        f"projected and resampled by the engine, in process; smallest of {m['repeats']} runs); POV-Ray's antialiasing: its render alone. POV-Ray baselines: +A0.0 "
        "(threshold 0: every pixel supersampled) with +AM1 (an n x n grid plus the centre ray, n = +R) or +AM2 "
        "(recursive subdivision from the pixel corners: a (2<sup>R&minus;1</sup>+1)<sup>2</sup> grid per pixel), "
        "-J; rays per pixel from POV-Ray's own statistics.</p>")
    H.append(f"<p class='note'>Made by <code>make compare</code> (scripts/compare.py, scripts/report_compare.py) in "
             f"{m['pipeline_s']:.0f} s; steps made this run: {esc(json.dumps(m['steps']))}; the Python module "
             f"{esc(m['tools'].get('module_sha'))}.</p>")
    H.append("</body></html>")
    return "\n".join(H)


# ---- README text ---------------------------------------------------------------------

def scene_tables(meta, rows, d):
    """The per-scene numbers as (title, note, header, body) tables of plain text cells."""
    m = meta
    fmax, fshow = d["max_factor"], m["show_factor"]
    out = []
    fs = sorted({e["factor"] for e in d["equal_rays"]})
    body = []
    for s in m["scenes"]:
        by = {e["factor"]: e for e in d["equal_rays"] if e["scene"] == s}
        k = d["crossover"].get(s)
        body.append([s] + [fmt(by[f]["ratio"], 3) if f in by else "n/a" for f in fs] +
                     ["never" if k is None else f"{k:g}"])
    out.append(("Min-error against conventional at equal rays",
                "Continuous L2 error of the best centred min-error method over the best conventional filter's, "
                "per factor; below 1: min-error is more accurate. Last column: the factor from which min-error "
                "stays lower.",
                ["scene"] + [f"f{f:g}" for f in fs] + ["lower from"], body))
    body = []
    for meth in m["methods"]:
        body.append([meth] + [fmt((one(rows, scene=s, method=meth, factor=fmax) or {}).get("rms"), 3)
                              for s in m["scenes"]])
    out.append((f"Displayed image against the reference's pixel averages (RMS, factor {fmax:g})",
                "Pixel averages are what box filtering converges to; the centred min-error displays sample f_app "
                "at pixel centres.", ["method"] + list(m["scenes"]), body))
    body = []
    for b in d["baselines"]:
        c = b.get("cheapest_rms_method")
        body.append([b["scene"], b["label"] or b["baseline"], fmt(b["rays_per_pixel"], 3), fmt(b["time_s"], 3),
                     fmt(b["rms"], 3), f"{c} f{b['cheapest_rms_factor']:g}" if c else "none measured",
                     fmt(b.get("cheapest_rms_time_s"), 3) if c else "", fmt(b.get("time_ratio_rms"), 3) if c else ""])
    out.append(("POV-Ray's antialiasing against the cheapest method as close",
                "Each setting's rays per pixel (POV-Ray's statistics), time and display RMS, and the cheapest "
                "(method, factor) here whose display RMS is as low.",
                ["scene", "POV-Ray", "rays/px", "time (s)", "display RMS", "cheapest as close", "its time (s)",
                 "time ratio"], body))
    body = [[x["scene"], f"{x['baseline']} ({x['rays_per_pixel']:.0f} rays/px)", fmt(x["l2"], 3),
             fmt(x["box_l2"], 3),
             f"{x['first_method']} f{x['first_factor']:g} ({fmt(x['first_l2'], 3)})" if x["first_method"] else "none"]
            for x in d["floors"]]
    out.append(("POV-Ray's antialiasing as a continuous image",
                f"Its deepest setting's continuous L2 error (piecewise constant), the box's at factor {fmax:g}, "
                "and the first (lowest factor) centred method below it.",
                ["scene", "POV-Ray", "L2", f"box f{fmax:g} L2", "first below"], body))
    ov = {(o["scene"], o["method"]): o for o in d["overshoot"]}
    body = []
    for meth in m["methods"]:
        cells = []
        for s in m["scenes"]:
            o = ov.get((s, meth))
            cells.append(f"{fmt(o['max_overshoot'], 3)} / {fmt(o['max_undershoot'], 3)} ({fmt(o['negative_pixels'])})"
                         if o else "n/a")
        body.append([meth] + cells)
    out.append((f"Overshoot and negative pixels (factor {fshow:g})",
                "Largest excursion above the local maximum / below the local minimum of the input samples "
                "(linear units) and, in brackets, the negative pixels, inside the border band.",
                ["method"] + list(m["scenes"]), body))
    return out


def md_table(header, body):
    return ["| " + " | ".join(header) + " |", "| --- |" + " ---: |" * (len(header) - 1)] + \
           ["| " + " | ".join(str(c) for c in r) + " |" for r in body]


def readme_md(meta, d, rows, link_prefix):
    m = meta
    f = d["max_factor"]
    L = ["## Results", ""]
    L.append(f"`make compare` renders {len(m['scenes'])} scenes ({', '.join(m['scenes'])}) at "
             f"{m['width']} x {m['height']}, factors {' '.join(f'{x:g}' for x in m['factors'])}, and a reference "
             f"at factor {m['ref_factor']:g} (the zone plate: its closed form); every method of the pipeline and "
             f"POV-Ray's own antialiasing (+A0.0, +AM1/+AM2, depths {', '.join(sorted({a[-1] for a in m['aa']}))}) "
             f"are timed and measured. The report, with the images, crops and difference images, is "
             f"`{link_prefix}index.html`; every number is in `{link_prefix}results.csv` and `results.json`.")
    L.append("")
    # docs/img/: copied there by make docs with this text
    L.append("![continuous L2 error against time](img/error-vs-time.png)")
    L.append("")
    L.append(f"Continuous L2 error of the approximation f_app against the reference, factor {f:g} "
             f"({f * f:g} rays per pixel), {m['border']}-pixel border left out (2x2 displays share f_app with "
             f"their centred method):")
    L.append("")
    L.append("| method | " + " | ".join(m["scenes"]) + " |")
    L.append("| --- |" + " ---: |" * len(m["scenes"]))
    for e in d["main"]:
        if e["factor"] == f and is_centred(m, e["method"]):
            best = {s: min((x[s] for x in d["main"] if x["factor"] == f and x[s] is not None), default=None)
                    for s in m["scenes"]}
            cells = [(f"**{fmt(e[s], 3)}**" if e[s] is not None and e[s] == best[s] else fmt(e[s], 3))
                     for s in m["scenes"]]
            L.append(f"| {e['method']} | " + " | ".join(cells) + " |")
    for am in ("1", "2"):
        bs = [b for b in d["baselines"] if b["baseline"].startswith(f"pov-am{am}")]
        if bs:
            top = max(b["rays_per_pixel"] or 0 for b in bs)
            sel = [b for b in bs if (b["rays_per_pixel"] or 0) == top]
            byscene = {b["scene"]: b for b in sel}
            label = sel[0]["label"]
            L.append(f"| {label} ({top:.0f} rays/px) | " +
                     " | ".join(fmt(byscene[s]["l2"], 3) if s in byscene else "n/a" for s in m["scenes"]) + " |")
    L.append("")
    L.append(f"High-pass energy share of the displayed image (%), factor {f:g}, mean of "
             f"{', '.join(d['ldr_scenes'])}, beside the seed's table (docs/design.md section 4; its cutoff unknown):")
    L.append("")
    L.append("| method | seed | " + " | ".join(f"ours, > {c:g} c/px" for c in m["cutoffs"]) + " |")
    L.append("| --- | ---: |" + " ---: |" * len(m["cutoffs"]))
    for e in d["hp"]:
        L.append(f"| {SEED_LABEL.get(e['method'], e['method'])} | {fmt(e['seed_percent'])} | " +
                 " | ".join(pct(e[f"ldr_mean@{c:g}"]) for c in m["cutoffs"]) + " |")
    L.append("")
    L.append("Conclusions:")
    L.append("")
    for x in d["findings"]:
        L.append(f"- {x}")
    L.append("")
    L.append("### Per scene")
    for title, note, header, body in scene_tables(meta, rows, d):
        L += ["", f"**{title}.** {note}", ""] + md_table(header, body)
    L.append("")
    return "\n".join(L)


# ---- entry ---------------------------------------------------------------------------

RESULT_FIELDS = ["scene", "kind", "method", "label", "factor", "rays_per_pixel", "render_s", "render_trace_s",
                 "project_s", "total_s", "l2", "l2_shared_with", "l2_against_render", "rms", "psnr"]


def build(report, work, meta, rows):
    report = os.path.abspath(report)
    os.makedirs(report, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix=".compare-tmp.", dir=report)
    try:
        os.makedirs(os.path.join(tmp, ASSETS, "charts"))
        d = derive(meta, rows)
        hp_fields = [hpkey(c) for c in meta["cutoffs"]]
        fields = RESULT_FIELDS + hp_fields + ["max_overshoot", "max_undershoot", "pixels_out_of_range",
                                              "negative_pixels", "negative_energy", "ov_min", "ov_max",
                                              "ov_pixels", "options", "image"]
        files = ["results.json", "results.csv", "main.csv", "hp.csv", "equal-rays.csv", "baseline.csv",
                 "README-results.md", "index.html"]
        write(tmp, "results.csv", csv_text(fields, rows))
        main_fields = ["factor", "rays_per_pixel", "method"] + meta["scenes"] + [s + "_time_s" for s in meta["scenes"]]
        write(tmp, "main.csv", csv_text(main_fields, d["main"]))
        hp_cols = ["method", "seed_percent"] + [f"{s}@{c:g}" for c in meta["cutoffs"] for s in meta["scenes"]] + \
                  [f"ldr_mean@{c:g}" for c in meta["cutoffs"]]
        write(tmp, "hp.csv", csv_text(hp_cols, d["hp"]))
        write(tmp, "equal-rays.csv", csv_text(["scene", "factor", "rays_per_pixel", "best_min_error", "min_error_l2",
                                               "best_conventional", "conventional_l2", "ratio", "winner"],
                                              d["equal_rays"]))
        base_cols = ["scene", "baseline", "label", "rays_per_pixel", "time_s", "l2", "rms"] + \
                    [f"cheapest_{k}_{x}" for k in ("l2", "rms") for x in ("method", "factor", "time_s", "value")] + \
                    ["time_ratio_l2", "time_ratio_rms"]
        write(tmp, "baseline.csv", csv_text(base_cols, d["baselines"]))

        charts = {k: f"{ASSETS}/charts/{v}" for k, v in (
            ("time", "error-vs-time.png"), ("display_time", "display-error-vs-time.png"),
            ("factor", "error-vs-factor.png"), ("hp", "highpass.png"), ("diff_scale", "diff-scale.png"))}
        charts["scene"] = {}
        chart_grid(os.path.join(tmp, charts["time"]), meta, rows, "l2", "continuous L2 error of f_app", "total_s",
                   "total time, render + projection (s)", True,
                   "Continuous L2 error against total time (points: factors; dotted: POV-Ray's antialiasing)")
        chart_grid(os.path.join(tmp, charts["display_time"]), meta, rows, "rms", "display RMS against reference",
                   "total_s", "total time, render + projection (s)", False,
                   "Displayed image against the reference's pixel averages: RMS against total time")
        chart_grid(os.path.join(tmp, charts["factor"]), meta, rows, "l2", "continuous L2 error of f_app", "factor",
                   "factor s (POV-Ray: sqrt of its rays per pixel)", True,
                   "Continuous L2 error against factor (equal rays)")
        chart_hp(os.path.join(tmp, charts["hp"]), meta, d)
        chart_diff_scale(os.path.join(tmp, charts["diff_scale"]))
        scene_cards = {}
        for s in meta["scenes"]:
            p = f"{ASSETS}/charts/{s}.png"
            chart_scene(os.path.join(tmp, p), meta, rows, s)
            charts["scene"][s] = p
            scene_cards[s] = scene_images(tmp, work, meta, rows, s)
        crops = {s: [{"x": x, "y": y, "size": v[3]} for (x, y) in v[1]] for s, v in scene_cards.items()}
        results = {"meta": meta, "rows": rows, "derived": {k: v for k, v in d.items() if k != "findings"},
                   "findings": d["findings"], "seed_hp_percent": SEED_HP, "crops": crops,
                   "diff_range": DIFF_RANGE}
        write(tmp, "results.json", json.dumps(results, indent=1, sort_keys=True, allow_nan=False) + "\n")
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        rp = os.path.abspath(report)
        prefix = (os.path.relpath(rp, root) + "/") if rp.startswith(root + os.sep) else ""
        write(tmp, "README-results.md", readme_md(meta, d, rows, prefix))
        # So do the stability study (make stability) and the hexagonal
        # comparison (make compare-hex): linked when there.
        linked = files + [f"{sub}/index.html" for sub in ("stability", "hex")
                          if os.path.exists(os.path.join(report, sub, "index.html"))]
        write(tmp, "index.html", build_html(meta, rows, d, charts, scene_cards, linked))
        # Into place: the asset folder swapped as a whole, then each file
        # (atomic renames; index.html last). Other files of REPORT are left alone.
        os.makedirs(report, exist_ok=True)
        for dirpath, dirnames, _ in os.walk(tmp):
            os.chmod(dirpath, 0o777 & ~current_umask())
        dst = os.path.join(report, ASSETS)
        old = None
        if os.path.lexists(dst):
            old = tempfile.mkdtemp(prefix=f".{ASSETS}.old.", dir=report)
            os.replace(dst, os.path.join(old, ASSETS))
        os.replace(os.path.join(tmp, ASSETS), dst)
        for name in [f for f in files if f != "index.html"] + ["index.html"]:
            os.replace(os.path.join(tmp, name), os.path.join(report, name))
        if old:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write(folder, name, text):
    with open(os.path.join(folder, name), "w") as f:
        f.write(text)
