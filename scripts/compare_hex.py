#!/usr/bin/env python3
"""compare_hex.py: the hexagonal lattice against the Cartesian one (make compare-hex).

    compare_hex.py --work DIR --report DIR [--res 256] [--factors "2 4 8"]
                   [--densities "0.8 0.866 0.933 1 1.07"] [--ref-factor 32]
                   [--spp 16] [--border 16] [--images "smooth zoneplate zoneplate-disk objects edges"]

Images, RES x RES output pixels (u, v in output pixels):
  smooth     0.5 + 0.2 sin(2 pi u / 37) cos(2 pi v / 23) + 0.1 cos(2 pi (u + 0.7 v) / 11),
             sampled in closed form (float32) at every factor; the truth the
             same closed form at SPP x SPP points per output pixel
  zoneplate  scenes/zoneplate.pov's plate with ZP_K = 0.7 pi RES (0.7 of
             Nyquist at the edges' middles), sampled in closed form; its
             truth the closed form (siproject.l2_error(zoneplate=K))
  zoneplate-disk  the same, the error over the inscribed disk (radius
             RES/2 - BORDER) only, where the plate's content is isotropic:
             f_app on the SPP x SPP grid against the closed form
  objects, edges  POV-Ray renders (make render, antialiasing off) at
             every factor; the truth the render at REF_FACTOR
The analytic images are sampled in float32 rather than rendered: POV-Ray
writes half-precision EXR, whose rounding (2.4e-4 at 0.5) would dominate
errors of 1e-5.

Methods (min-error, mirror rule): the Cartesian tent and cubic at one
coefficient per output pixel; the hex hat and hex quartic at each DENSITY,
lattice points per output pixel (0.866 is the 13.4 % fewer the hexagonal
lattice promises for an isotropic band limit).

Measures: the continuous L2 error of f_app, BORDER output pixels left out
along each edge (siproject.Reference); the projection's time in this process
(siproject.coefficients from the samples in memory or the render's file, the
smallest of 3 runs).

Derived: per image and factor, the density at which each hex generator's
error equals its Cartesian peer's (hat and tent, quartic and cubic), log
error interpolated linearly in log density between the densities measured;
the saving is 1 - that density.

Writes REPORT/index.html, results.json, results.csv and error-vs-density.png
(the folder built aside and renamed into place). Renders are make's
render targets in WORK/render (make render OUT=WORK ...), remade under the
Makefile's one staleness rule. Any failure: a
message on stderr, exit status 1, no partial report.
"""
import argparse
import csv
import html
import io
import json
import math
import os
import shutil
import sys
import tempfile
import time

import numpy as np

try:
    import siproject
except ImportError as e:
    sys.exit(f"compare_hex: the Python module siproject is missing ({e}): run make build")
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from atomic import write_atomic  # noqa: E402
from renders import RenderError, make_render  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PAIRS = [("hex-hat", "tent"), ("hex-quartic", "cubic")]


class StudyError(Exception):
    pass


def say(message):
    print(message, file=sys.stderr, flush=True)


def smooth(u, v):
    return (0.5 + 0.2 * np.sin(2 * np.pi * u / 37) * np.cos(2 * np.pi * v / 23)
            + 0.1 * np.cos(2 * np.pi * (u + 0.7 * v) / 11))


def zoneplate(u, v, res, K):
    a, b = u / res - 0.5, v / res - 0.5
    return 0.5 + 0.5 * np.cos(K * (a * a + b * b))


def sampled(f, res, s):
    """f at the centres of an (res s)^2 grid over res x res output pixels, float32 (H, W, 1)."""
    x = (np.arange(res * s) + 0.5) / s
    return f(x[None, :], x[:, None]).astype(np.float32)[:, :, None]


def render(work, scene, res, factor):
    """scenes/SCENE.pov at RES x RES output pixels and FACTOR, made by make in
    WORK (scripts/renders.py: the Makefile's render target and staleness
    rule)."""
    try:
        return make_render(work, scene, res, factor)[0]
    except RenderError as e:
        raise StudyError(str(e))


def methods(densities):
    out = [(g, 1.0, dict(generator=g)) for g in ("tent", "cubic")]
    for g, _ in PAIRS:
        for d in densities:
            out.append((g, d, dict(lattice="hex", generator=g, density=d)))
    return out


def measure(images, cfg):
    rows = []
    for name in images:
        say(f"image    {name}")
        if name == "smooth":
            inputs = {s: sampled(smooth, cfg.res, s) for s in cfg.factors}
            ref = siproject.Reference(sampled(smooth, cfg.res, cfg.spp), border=cfg.border)
            error = ref.l2_error
        elif name == "zoneplate":
            K = 0.7 * math.pi * cfg.res
            inputs = {s: sampled(lambda u, v: zoneplate(u, v, cfg.res, K), cfg.res, s) for s in cfg.factors}

            def error(k, K=K):
                return siproject.l2_error(k, zoneplate=K, samples_per_pixel=cfg.spp, border=cfg.border)
        elif name == "zoneplate-disk":
            # The plate's content is isotropic only on the inscribed disk (the
            # corners reach 0.7 sqrt(2) of Nyquist along the diagonals): f_app
            # on the truth grid, the RMS over the disk of radius RES/2 - BORDER.
            K = 0.7 * math.pi * cfg.res
            inputs = {s: sampled(lambda u, v: zoneplate(u, v, cfg.res, K), cfg.res, s) for s in cfg.factors}
            n = cfg.res * cfg.spp
            x = (np.arange(n) + 0.5) / cfg.spp
            truth = zoneplate(x[None, :], x[:, None], cfg.res, K)
            disk = (x[None, :] - cfg.res / 2) ** 2 + (x[:, None] - cfg.res / 2) ** 2 <= (cfg.res / 2 - cfg.border) ** 2

            def error(k, truth=truth, disk=disk, n=n):
                app = k.resample((n, n), display="centred")[:, :, 0].astype(np.float64)
                return float(np.sqrt(np.mean((app - truth)[disk] ** 2)))
        else:
            inputs = {s: render(cfg.work, name, cfg.res, s) for s in cfg.factors}
            ref = siproject.Reference(siproject.read_image(render(cfg.work, name, cfg.res, cfg.ref_factor)),
                                      border=cfg.border)
            error = ref.l2_error
        for s in cfg.factors:
            for g, d, kw in methods(cfg.densities):
                times = []
                for _ in range(3):
                    t0 = time.perf_counter()
                    k = siproject.coefficients(inputs[s], size=cfg.res, **kw)
                    times.append(time.perf_counter() - t0)
                # lattice points over the frame (the stored hexagonal grid
                # also covers a margin around it)
                coefficients = int(round(d * cfg.res * cfg.res))
                rows.append({"image": name, "factor": s, "generator": g, "lattice": k.lattice,
                             "density": d, "coefficients": coefficients, "l2": error(k),
                             "project_s": min(times)})
            say(f"         factor {s}: " + ", ".join(
                f"{r['generator']}@{r['density']:g} {r['l2']:.3g}" for r in rows
                if r["image"] == name and r["factor"] == s and r["density"] in (1.0, 0.866)))
    return rows


def break_even(rows, image, factor, hexg, cartg):
    """Density where the hex error meets the Cartesian one (None: not within the densities)."""
    cart = next(r["l2"] for r in rows if r["image"] == image and r["factor"] == factor
                and r["generator"] == cartg)
    pts = sorted((r["density"], r["l2"]) for r in rows if r["image"] == image and r["factor"] == factor
                 and r["generator"] == hexg)
    for (d0, e0), (d1, e1) in zip(pts, pts[1:]):
        if (e0 - cart) * (e1 - cart) <= 0 and e0 != e1:
            t = (math.log(cart) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(d0) + t * (math.log(d1) - math.log(d0)))
    return None


def derived(rows, cfg, images):
    out = []
    for image in images:
        for s in cfg.factors:
            for hexg, cartg in PAIRS:
                d = break_even(rows, image, s, hexg, cartg)
                at1 = next(r["l2"] for r in rows if r["image"] == image and r["factor"] == s
                           and r["generator"] == hexg and r["density"] == 1.0)
                cart = next(r["l2"] for r in rows if r["image"] == image and r["factor"] == s
                            and r["generator"] == cartg)
                out.append({"image": image, "factor": s, "hex": hexg, "cartesian": cartg,
                            "ratio_at_equal_count": at1 / cart, "break_even_density": d,
                            "saving": None if d is None else 1 - d})
    return out


def chart(rows, cfg, images, path):
    fig, axes = plt.subplots(1, len(images), figsize=(4.2 * len(images), 4), squeeze=False)
    colours = dict(zip(cfg.factors, ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple"]))
    for ax, image in zip(axes[0], images):
        for s in cfg.factors:
            for hexg, cartg in PAIRS:
                pts = sorted((r["density"], r["l2"]) for r in rows if r["image"] == image
                             and r["factor"] == s and r["generator"] == hexg)
                style = "-" if hexg == "hex-quartic" else ":"
                ax.plot([p[0] for p in pts], [p[1] for p in pts], style, marker="o", ms=3,
                        color=colours[s], label=f"{hexg} f{s:g}")
                cart = next(r["l2"] for r in rows if r["image"] == image and r["factor"] == s
                            and r["generator"] == cartg)
                ax.axhline(cart, color=colours[s], ls="--" if cartg == "cubic" else "-.", lw=0.8,
                           label=f"{cartg} f{s:g} (density 1)")
        ax.axvline(0.866, color="grey", lw=0.6)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(image)
        ax.set_xlabel("hex lattice points per output pixel")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("continuous L2 error")
    axes[0][-1].legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.02, 1))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def fmt(v, spec=".3g"):
    return "-" if v is None else format(v, spec)


def page(rows, der, cfg, images):
    h = ["<!doctype html><html><head><meta charset='utf-8'><title>Hexagonal lattice against Cartesian</title>",
         "<style>body{font-family:sans-serif;max-width:1200px;margin:2em auto}table{border-collapse:collapse;"
         "margin:1em 0}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}</style></head><body>",
         "<h1>Hexagonal lattice against Cartesian</h1>",
         f"<p>{cfg.res} x {cfg.res} output pixels, factors {', '.join(f'{s:g}' for s in cfg.factors)}, "
         f"continuous L2 error with a {cfg.border}-pixel border left out; hex at densities "
         f"{', '.join(f'{d:g}' for d in cfg.densities)} lattice points per output pixel (0.866: 13.4 % fewer "
         "coefficients); Cartesian at one coefficient per output pixel. Made by "
         "<code>make compare-hex</code> (scripts/compare_hex.py).</p>",
         "<h2>Where the hexagonal lattice meets the Cartesian error</h2>",
         "<table><tr><th>image</th><th>factor</th><th>pair</th><th>hex / Cartesian error at equal count</th>"
         "<th>density where they meet</th><th>saving</th></tr>"]
    for d in der:
        h.append(f"<tr><td>{d['image']}</td><td>{d['factor']:g}</td><td>{d['hex']} / {d['cartesian']}</td>"
                 f"<td>{d['ratio_at_equal_count']:.3f}</td><td>{fmt(d['break_even_density'], '.3f')}</td>"
                 f"<td>{fmt(None if d['saving'] is None else 100 * d['saving'], '.1f')}"
                 f"{'' if d['saving'] is None else ' %'}</td></tr>")
    h.append("</table><p>The saving is 1 - the density where they meet: the share of coefficients the "
             "hexagonal lattice spares at equal error (below 0: it needs more); '-': the errors do not meet "
             "within the densities measured.</p>")
    h.append("<img src='error-vs-density.png' alt='error against density' style='max-width:100%'>")
    h.append("<h2>Every measure</h2><table><tr><th>image</th><th>factor</th><th>generator</th><th>density</th>"
             "<th>lattice points over the frame</th><th>L2 error</th><th>projection (s)</th></tr>")
    for r in rows:
        h.append(f"<tr><td>{r['image']}</td><td>{r['factor']:g}</td><td>{r['generator']}</td>"
                 f"<td>{r['density']:g}</td><td>{r['coefficients']}</td><td>{r['l2']:.4g}</td>"
                 f"<td>{r['project_s']:.3f}</td></tr>")
    h.append("</table><p><a href='results.json'>results.json</a>, <a href='results.csv'>results.csv</a></p>"
             "</body></html>")
    return "\n".join(h)


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--work", required=True)
    p.add_argument("--report", required=True)
    p.add_argument("--res", type=int, default=256)
    p.add_argument("--factors", default="2 4 8")
    p.add_argument("--densities", default="0.8 0.866 0.933 1 1.07")
    p.add_argument("--ref-factor", type=int, default=32)
    p.add_argument("--spp", type=int, default=16, help="truth samples per output pixel per axis")
    p.add_argument("--border", type=int, default=16)
    p.add_argument("--images", default="smooth zoneplate zoneplate-disk objects edges")
    cfg = p.parse_args(argv)
    try:
        cfg.factors = [int(x) for x in cfg.factors.split()]
        cfg.densities = sorted(float(x) for x in cfg.densities.split())
    except ValueError as e:
        raise StudyError(f"--factors and --densities take numbers: {e}")
    if 1.0 not in cfg.densities:
        raise StudyError("--densities must include 1 (equal coefficient count)")
    images = cfg.images.split()
    if not images or not cfg.factors or not cfg.densities:
        raise StudyError("--images, --factors and --densities must each name at least one")
    if any(s < 1 for s in cfg.factors) or any(not d > 0 for d in cfg.densities):
        raise StudyError("--factors must be integers >= 1 and --densities numbers > 0")
    for name in images:
        if name not in ("smooth", "zoneplate", "zoneplate-disk") and not os.path.exists(os.path.join(ROOT, "scenes", name + ".pov")):
            raise StudyError(f"--images: no closed form and no scenes/{name}.pov for '{name}'")
    t0 = time.perf_counter()
    rows = measure(images, cfg)
    der = derived(rows, cfg, images)
    report = os.path.abspath(cfg.report)
    os.makedirs(os.path.dirname(report), exist_ok=True)
    stage = tempfile.mkdtemp(prefix=".compare-hex.", dir=os.path.dirname(report))
    try:
        with open(os.path.join(stage, "results.json"), "w") as f:
            json.dump({"res": cfg.res, "factors": cfg.factors, "densities": cfg.densities,
                       "border": cfg.border, "spp": cfg.spp, "ref_factor": cfg.ref_factor,
                       "rows": rows, "derived": der}, f, indent=1)
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
        with open(os.path.join(stage, "results.csv"), "w") as f:
            f.write(buf.getvalue())
        chart(rows, cfg, images, os.path.join(stage, "error-vs-density.png"))
        with open(os.path.join(stage, "index.html"), "w") as f:
            f.write(page(rows, der, cfg, images))
        os.chmod(stage, 0o777 & ~0o022)
        if os.path.isdir(report):
            shutil.rmtree(report)
        os.replace(stage, report)
    finally:
        if os.path.isdir(stage):
            shutil.rmtree(stage)
    say(f"compare-hex: {os.path.join(report, 'index.html')} ({time.perf_counter() - t0:.0f} s)")
    for d in der:
        say(f"  {d['image']:<10} f{d['factor']:<2g} {d['hex']:<12} / {d['cartesian']:<5}: "
            f"{d['ratio_at_equal_count']:.3f} at equal count, meet at density "
            f"{fmt(d['break_even_density'], '.3f')}")


if __name__ == "__main__":
    try:
        main(sys.argv[1:])
    except StudyError as e:
        sys.exit(f"compare_hex: {e}")
    except (ValueError, OSError, RuntimeError) as e:  # from the module: its message names the cause
        sys.exit(f"compare_hex: {e}")
    except KeyboardInterrupt:
        sys.exit(130)
