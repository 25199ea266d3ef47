#!/usr/bin/env python3
"""The sample patterns compared (make compare-samples): for every scene,
pattern, density and seed, the render make made (renders are make targets:
out/compare-samples*/render/SCENE-RES-fFACTOR[-PATTERN-sSEED].exr, named as
the Makefile names them), projected by each method through the module; the
continuous L2 error against the truth (the zone plate's closed form, or the
regular reference render at --ref-factor), the displayed image's RMS error
against the same method's image of the reference (the zone plate: its
closed form at the pixel centres), the high-pass share above 0.25
cycles/pixel, their mean and spread max - min across seeds, the render's
wall time (the .NAME.seconds file scripts/timed_make.sh wrote beside it:
for a mesh render sirays, POV-Ray's parse and trace of every band and the
assembly) and the projection's time. On the --ref-check scenes the centred
methods' errors at seed 0 are also measured against a regular reference at
--ref-alt-factor and a jittered one (seed 0) at --ref-factor, the latter as
the RMS of f_app - f over its samples inside the border (f_app evaluated
there), beside the same estimate over the regular reference's samples.
Writes REPORT/samples.md, samples.csv, refcheck.csv and two charts (error
against rays per pixel and against total time, by pattern, per method).

    compare_samples.py --work DIR --report DIR --scenes "..." --res N
        --factors "2 4" --seeds "0 1" --ref-factor 8 [--ref-check "checker"
        --ref-alt-factor 4] --zp-nyquist 0.7
"""

import argparse
import csv
import math
import os
import sys
import time

import numpy as np

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import siproject  # noqa: E402

from renders import render_path  # noqa: E402  (make render's own names)
from report_compare import SEED_HP  # noqa: E402

METHODS = {
    "conv-tent": dict(generator="tent", method="conventional", display="centred"),
    "mitchell": dict(generator="mitchell", method="conventional", display="centred"),
    "me-tent": dict(generator="tent", method="min-error", display="centred"),
    "me-cubic": dict(generator="cubic", method="min-error", display="centred"),
    "me-cubic-2x2": dict(generator="cubic", method="min-error", display="2x2"),
}
CONVENTIONAL = ("conv-tent", "mitchell")
MIN_ERROR = ("me-tent", "me-cubic")  # me-cubic-2x2 shares me-cubic's f_app
CENTRED = CONVENTIONAL + MIN_ERROR
PATTERNS = ("regular", "jitter", "sobol")
PATTERN_STYLE = {"regular": dict(color="black", marker="s"),
                 "jitter": dict(color="tab:orange", marker="o"),
                 "sobol": dict(color="tab:blue", marker="^")}
# The seed's order of the high-pass share (docs/design.md section 4), of these methods.
SEED_ORDER = sorted(METHODS, key=lambda m: -SEED_HP[m])


class StudyError(Exception):
    pass


def render_seconds(path):
    """The render's wall time scripts/timed_make.sh wrote, or NaN."""
    side = os.path.join(os.path.dirname(path), "." + os.path.splitext(os.path.basename(path))[0] + ".seconds")
    try:
        with open(side) as f:
            return float(f.read())
    except (OSError, ValueError):
        return math.nan


def zoneplate(x, y, w, h, k):
    u, v = x / w, y / h
    return 0.5 + 0.5 * np.cos(k * ((u - 0.5) ** 2 + (v - 0.5) ** 2))


def need(path):
    if not os.path.isfile(path):
        raise StudyError(f"{path}: no such render (make compare-samples makes it)")
    return path


def sampled_l2(k, values, positions, w, h, border, share=1.0, chunk=1 << 21):
    """RMS of f_app - f over the samples inside the border: f at POSITIONS (N, 2)
    holds VALUES (N, C), f_app is K evaluated there; all channels. SHARE < 1
    takes that share of the samples, each independently (a fixed seed): an
    unbiased estimate of the same mean square."""
    inside = ((positions[:, 0] >= border) & (positions[:, 0] <= w - border) &
              (positions[:, 1] >= border) & (positions[:, 1] <= h - border))
    if share < 1.0:
        inside &= np.random.default_rng(0).random(len(positions)) < share
    total, count = 0.0, 0
    for a in range(0, len(positions), chunk):
        sel = inside[a:a + chunk]
        p = positions[a:a + chunk][sel]
        if len(p) == 0:
            continue
        d = k.evaluate(p[:, 0], p[:, 1]).astype(np.float64) - values[a:a + chunk][sel]
        total += float(np.sum(d * d))
        count += d.size
    return math.sqrt(total / count)


def ref_check(a, scene, W, H):
    """The centred methods' L2 errors at seed 0 against three references."""
    reg = siproject.read_image(need(render_path(a.work, scene, a.res, a.ref_factor, "regular", 0)))
    alt = siproject.Reference(siproject.read_image(
        need(render_path(a.work, scene, a.res, a.ref_alt_factor, "regular", 0))), border=a.border)
    truth = siproject.Reference(reg, border=a.border)
    rays = float(a.ref_factor) ** 2
    refs = {"regular": (reg.reshape(-1, reg.shape[-1]).astype(np.float64),
                        siproject.sample_positions("regular", seed=0, size=(W, H), rays_per_pixel=rays))}
    jit = siproject.read_image(need(render_path(a.work, scene, a.res, a.ref_factor, "jitter", 0)))
    refs["jitter"] = (jit.reshape(-1, jit.shape[-1]).astype(np.float64),
                      siproject.sample_positions("jitter", seed=0, size=(W, H), rays_per_pixel=rays))
    del reg, jit
    out = []
    for factor in a.factors.split():
        for pattern in PATTERNS:
            path = render_path(a.work, scene, a.res, factor, pattern, a.seeds.split()[0])
            for m in CENTRED:
                kw = METHODS[m]
                k = siproject.coefficients(path, size=(W, H), generator=kw["generator"], method=kw["method"])
                out.append(dict(scene=scene, pattern=pattern, rays=float(factor) ** 2, method=m,
                                l2_ref=truth.l2_error(k), l2_alt=alt.l2_error(k),
                                l2_sampled_regular=sampled_l2(k, *refs["regular"], W, H, a.border,
                                                              a.check_share),
                                l2_sampled_jitter=sampled_l2(k, *refs["jitter"], W, H, a.border,
                                                             a.check_share)))
    return out


def measure(a, W, H):
    zp_k = float("%.6f" % (a.zp_nyquist * math.pi * W))  # as the Makefile declares ZP_K
    seeds = a.seeds.split()
    rows = []
    ys, xs = np.mgrid[0:H, 0:W] + 0.5
    b = int(a.border)
    for scene in a.scenes.split():
        truth = None
        if scene != "zoneplate":
            ref = need(render_path(a.work, scene, a.res, a.ref_factor, "regular", 0))
            truth = siproject.Reference(siproject.read_image(ref), border=a.border)
            shown = {m: siproject.project(ref, size=(W, H), **kw) for m, kw in METHODS.items()}
        else:
            z = zoneplate(xs, ys, W, H, zp_k)[..., None]
            shown = {m: z for m in METHODS}
        for factor in a.factors.split():
            rays = float(factor) ** 2
            for pattern in PATTERNS:
                for seed in (seeds[:1] if pattern == "regular" else seeds):
                    path = need(render_path(a.work, scene, a.res, factor, pattern, seed))
                    print(f"compare-samples: {os.path.basename(path)}", file=sys.stderr, flush=True)
                    render_s = render_seconds(path)
                    for m, kw in METHODS.items():
                        t = time.perf_counter()
                        k = siproject.coefficients(path, size=(W, H), generator=kw["generator"],
                                                   method=kw["method"])
                        image = k.resample(display=kw["display"])
                        seconds = time.perf_counter() - t
                        if truth is None:
                            l2 = siproject.l2_error(k, zoneplate=zp_k, border=a.border)
                        else:
                            l2 = truth.l2_error(k)
                        s = shown[m][b:H - b, b:W - b, :1]
                        rms = float(np.sqrt(np.mean((image[b:H - b, b:W - b, :1] - s) ** 2)))
                        hp = float(siproject.highpass_share(image, 0.25))
                        rows.append(dict(scene=scene, pattern=pattern, rays=rays, seed=seed, method=m,
                                         l2=l2, rms=rms, hp=hp, project_s=seconds, render_s=render_s,
                                         total_s=render_s + seconds))
    return rows


# ---- summaries -----------------------------------------------------------------

def group(rows):
    g = {}
    for r in rows:
        g.setdefault((r["scene"], r["method"], r["rays"], r["pattern"]), []).append(r)
    return g


def mean_of(g, key, *k):
    return float(np.mean([r[key] for r in g[k]]))


def spearman(a, b):
    """Rank correlation of two orders of the same items (lists, best first)."""
    n = len(a)
    return 1 - 6 * sum((a.index(x) - b.index(x)) ** 2 for x in a) / (n * (n * n - 1))


def f(x, digits=4):
    if x is None or not np.isfinite(x):
        return "n/a"
    return f"{x:.{digits}g}"


def table(header, body):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in body]
    return out


def report_md(a, rows, checks, W, H):
    g = group(rows)
    scenes = a.scenes.split()
    rays_list = sorted({r["rays"] for r in rows})
    rl = [f"{x:g}" for x in rays_list]
    seeds = a.seeds.split()
    L = [f"# Sample patterns ({W} x {H})", "",
         f"Scenes {', '.join(scenes)}; {', '.join(rl)} rays per pixel; patterns regular (POV-Ray's camera), "
         f"jitter and sobol (a mesh camera), seeds {', '.join(seeds)} (regular: one render). Truth: the zone "
         f"plate's closed form, else the regular render at factor {a.ref_factor} ({float(a.ref_factor) ** 2:g} "
         f"rays per pixel); border {a.border:g} px. Jitter and sobol: mean over seeds. Every number is in "
         f"samples.csv.", "",
         "![continuous L2 error against rays per pixel, by pattern](samples.png)", "",
         "![continuous L2 error against total time, by pattern](samples-time.png)", ""]

    # Min-error's advantage.
    L += ["## Min-error's advantage", "",
          "Continuous L2 error of the best min-error method (tent or cubic) over the best conventional one "
          "(tent or Mitchell), each pattern's mean; below 1: min-error is more accurate.", ""]
    body = []
    for s in scenes:
        for p in PATTERNS:
            cells = []
            for x in rays_list:
                me = min(mean_of(g, "l2", s, m, x, p) for m in MIN_ERROR)
                cv = min(mean_of(g, "l2", s, m, x, p) for m in CONVENTIONAL)
                cells.append(f"{me / cv:.3f}")
            body.append([s, p] + cells)
    L += table(["scene", "pattern"] + [f"{x} rays/px" for x in rl], body) + [""]

    # Pattern against regular, per method.
    L += ["## The patterns against the regular grid", "",
          "Continuous L2 error under jitter and sobol over the regular grid's, same method and density "
          "(mean over seeds); below 1: the pattern is more accurate.", ""]
    body = []
    for s in scenes:
        for m in CENTRED:
            cells = []
            for p in ("jitter", "sobol"):
                for x in rays_list:
                    cells.append(f"{mean_of(g, 'l2', s, m, x, p) / mean_of(g, 'l2', s, m, x, 'regular'):.3f}")
            body.append([s, m] + cells)
    L += table(["scene", "method"] + [f"jitter {x}" for x in rl] + [f"sobol {x}" for x in rl], body) + [""]

    # Orders.
    L += ["## The order of the methods", "",
          "By continuous L2 error (mean), most accurate first, at each density; the same order under every "
          "pattern is marked \"=\".", ""]
    body = []
    for s in scenes:
        for x in rays_list:
            orders = {p: sorted(CENTRED, key=lambda m: mean_of(g, "l2", s, m, x, p)) for p in PATTERNS}
            same = all(orders[p] == orders["regular"] for p in PATTERNS)
            body.append([s, f"{x:g}"] + [" < ".join(orders[p]) for p in PATTERNS] + ["=" if same else "differ"])
    L += table(["scene", "rays/px", "regular", "jitter", "sobol", ""], body) + [""]
    L += ["By the high-pass share above 0.25 cycles/pixel, highest first, beside the seed's order "
          f"({' > '.join(SEED_ORDER)}, docs/design.md section 4): the rank correlation with it, per "
          "pattern (1: the seed's order).", ""]
    body = []
    for s in scenes:
        cells = []
        for p in PATTERNS:
            for x in rays_list:
                o = sorted(METHODS, key=lambda m: -mean_of(g, "hp", s, m, x, p))
                cells.append(f"{spearman(o, SEED_ORDER):.2f}")
        body.append([s] + cells)
    L += table(["scene"] + [f"{p} {x}" for p in PATTERNS for x in rl], body) + [""]

    # Time.
    L += ["## What the mesh costs", "",
          "The render's wall time in seconds (regular: POV-Ray's camera; jitter and sobol: the mesh bands' "
          "scenes written by sirays, POV-Ray's parse and trace, the assembly; each with make's start-up), "
          "jitter and sobol the median over seeds, and their ratio to the regular render's.", ""]
    body = []
    for s in scenes:
        for x in rays_list:
            reg = float(np.median([r["render_s"] for r in g[(s, "me-cubic", x, "regular")]]))
            cells = [f(reg, 3)]
            for p in ("jitter", "sobol"):
                t = float(np.median([r["render_s"] for r in g[(s, "me-cubic", x, p)]]))
                cells += [f(t, 3), f(t / reg, 3)]
            body.append([s, f"{x:g}"] + cells)
    L += table(["scene", "rays/px", "regular (s)", "jitter (s)", "jitter / regular", "sobol (s)",
                "sobol / regular"], body) + [""]

    # Reference check.
    if checks:
        L += ["## The reference's own grid", "",
              f"Centred methods at seed {seeds[0]}: the continuous L2 error against the regular reference at "
              f"factor {a.ref_factor} (the study's truth), against a regular one at factor {a.ref_alt_factor}, "
              f"and the RMS of f_app - f over the samples of the regular and of a jittered (seed 0) reference "
              f"at factor {a.ref_factor} (f_app evaluated there). Largest relative difference from the truth's "
              f"error, and whether the order of the methods changes:", ""]
        body = []
        for s in sorted({c["scene"] for c in checks}):
            cs = [c for c in checks if c["scene"] == s]
            for key, what in (("l2_alt", f"regular, factor {a.ref_alt_factor}"),
                              ("l2_sampled_regular", f"regular, factor {a.ref_factor}, at its samples"),
                              ("l2_sampled_jitter", f"jitter, factor {a.ref_factor}, at its samples")):
                rel = max(abs(c[key] / c["l2_ref"] - 1) for c in cs)
                changed = 0
                for x in rays_list:
                    for p in PATTERNS:
                        sub = [c for c in cs if c["rays"] == x and c["pattern"] == p]
                        if sorted(sub, key=lambda c: c["l2_ref"]) != sorted(sub, key=lambda c: c[key]):
                            changed += 1
                body.append([s, what, f"{100 * rel:.3g} %", f"{changed} of {len(rays_list) * len(PATTERNS)}"])
        L += table(["scene", "reference", "largest difference", "orders changed"], body) + [""]
        L += ["Every error (refcheck.csv):", ""]
        body = [[c["scene"], c["method"], f"{c['rays']:g}", c["pattern"], f(c["l2_ref"], 5), f(c["l2_alt"], 5),
                 f(c["l2_sampled_regular"], 5), f(c["l2_sampled_jitter"], 5)] for c in checks]
        L += table(["scene", "method", "rays/px", "pattern", f"ref f{a.ref_factor}", f"ref f{a.ref_alt_factor}",
                    f"f{a.ref_factor} samples", f"jitter f{a.ref_factor} samples"], body) + [""]

    # All numbers.
    L += ["## All numbers", "",
          "Mean over seeds and spread (max - min); time: the render's wall time plus the projection's "
          "(mean over seeds).", ""]
    body = []
    for (s, m, x, p), rs in g.items():
        l2 = np.array([r["l2"] for r in rs])
        rms = np.array([r["rms"] for r in rs])
        body.append([s, m, f"{x:g}", p, f"{l2.mean():.5f}", f"{np.ptp(l2):.5f}", f"{rms.mean():.5f}",
                     f"{np.ptp(rms):.5f}", f"{np.mean([r['hp'] for r in rs]):.4f}",
                     f(float(np.mean([r['render_s'] for r in rs])), 3),
                     f"{np.mean([r['project_s'] for r in rs]):.3f}"])
    L += table(["scene", "method", "rays/px", "pattern", "L2 error", "spread", "displayed RMS", "spread",
                "hp>0.25", "render (s)", "projection (s)"], body)
    return "\n".join(L) + "\n"


def charts(a, rows, report):
    g = group(rows)
    scenes = a.scenes.split()
    for name, xkey, xlabel in (("samples.png", "rays", "rays per pixel"),
                               ("samples-time.png", "total_s", "render + projection time (s)")):
        fig, axes = plt.subplots(len(scenes), len(METHODS), figsize=(2.9 * len(METHODS), 2.5 * len(scenes)),
                                 squeeze=False)
        for i, scene in enumerate(scenes):
            for j, m in enumerate(METHODS):
                ax = axes[i][j]
                for pattern in PATTERNS:
                    # in the order of density, so that each line runs from the fewest rays to the most
                    pts = [q for _, q in sorted(
                        (x, (float(np.mean([r[xkey] for r in rs])), float(np.mean([r["l2"] for r in rs]))))
                        for (s, mm, x, p), rs in g.items() if s == scene and mm == m and p == pattern)]
                    pts = [q for q in pts if np.isfinite(q[0])]
                    ax.plot([q[0] for q in pts], [q[1] for q in pts], label=pattern, lw=1, ms=4,
                            **PATTERN_STYLE[pattern])
                ax.set_xscale("log", base=2)
                ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
                ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
                ax.tick_params(labelsize=7)
                ax.set_title(f"{scene}: {m}", fontsize=8)
                if i == len(scenes) - 1:
                    ax.set_xlabel(xlabel, fontsize=8)
                if j == 0:
                    ax.set_ylabel("continuous L2 error", fontsize=8)
        axes[0][0].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(report, name), dpi=80)
        plt.close(fig)


def write_csv(path, rows):
    with open(path + ".tmp", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(path + ".tmp", path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--report", required=True)
    ap.add_argument("--scenes", required=True)
    ap.add_argument("--res", type=int, required=True)
    ap.add_argument("--factors", required=True)
    ap.add_argument("--seeds", required=True)
    ap.add_argument("--ref-factor", required=True)
    ap.add_argument("--ref-check", default="", help="scenes whose reference's grid is checked")
    ap.add_argument("--ref-alt-factor", default=None)
    ap.add_argument("--zp-nyquist", type=float, default=0.7)
    ap.add_argument("--border", type=float, default=4)
    ap.add_argument("--check-share", type=float, default=1.0,
                    help="share of the references' samples the sampled check evaluates (0 < S <= 1)")
    a = ap.parse_args()
    W = H = a.res
    check_scenes = [s for s in a.ref_check.split() if s in a.scenes.split() and s != "zoneplate"]
    if check_scenes and not a.ref_alt_factor:
        ap.error("--ref-check needs --ref-alt-factor")
    if not 0.0 < a.check_share <= 1.0:
        ap.error(f"--check-share {a.check_share}: must be in (0, 1]")
    try:
        rows = measure(a, W, H)
        checks = [c for s in check_scenes for c in ref_check(a, s, W, H)]
    except (StudyError, ValueError, OSError, RuntimeError) as e:
        print(f"compare_samples.py: {e}", file=sys.stderr)
        return 1
    os.makedirs(a.report, exist_ok=True)
    write_csv(os.path.join(a.report, "samples.csv"), rows)
    if checks:
        write_csv(os.path.join(a.report, "refcheck.csv"), checks)
    charts(a, rows, a.report)
    md = os.path.join(a.report, "samples.md")
    with open(md + ".tmp", "w") as fh:
        fh.write(report_md(a, rows, checks, W, H))
    os.replace(md + ".tmp", md)
    print(f"compare-samples: {md}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
