#!/usr/bin/env python3
"""Fewer rays than pixels (make compare-sparse): at 0.25, 0.5 and 1 ray per
pixel (Owen-scrambled Sobol' positions, make SAMPLES=sobol, FACTOR = sqrt of
the rays per pixel), the continuous L2 error against the regular reference
render at --ref-factor of: the variational rule (thin plate, lambda by GCV),
the least-squares fit and the normalised sum (cubic, min-error), scipy's
griddata linear and cubic of the same rays (evaluated on a 4 x 4 grid per
pixel, nearest outside the rays' hull, then projected min-error onto the
cubic space for its continuous error), and the regular factor-1 render
filtered conventionally with the tent. Writes REPORT/sparse.csv and
REPORT/sparse.md.

    compare_sparse.py --work DIR --report DIR --scenes "objects" --res 128
        --ref-factor 16 --seed 0
"""

import argparse
import csv
import math
import os
import sys
import time

import numpy as np
from scipy.interpolate import griddata

import siproject
from renders import render_path  # noqa: E402  (make render's own names)

DENSITIES = (("0.25", "0.5"), ("0.5", "0.70710678"), ("1", "1"))  # (rays per pixel, FACTOR)
RULES = ("variational", "fit", "normalised")


def need(path):
    if not os.path.isfile(path):
        sys.exit(f"compare_sparse.py: {path}: no such render (make compare-sparse makes it)")
    return path


def griddata_coefficients(positions, values, W, H, kind):
    """griddata of the rays on a 4 x 4 grid a pixel, projected min-error (cubic)."""
    s = 4
    ys, xs = np.mgrid[0:H * s, 0:W * s]
    pts = np.stack([(xs.ravel() + 0.5) / s, (ys.ravel() + 0.5) / s], axis=1)
    out = np.empty((H * s, W * s, values.shape[1]), np.float32)
    for c in range(values.shape[1]):
        v = griddata(positions, values[:, c], pts, method=kind)
        bad = ~np.isfinite(v)
        if bad.any():
            v[bad] = griddata(positions, values[:, c], pts[bad], method="nearest")
        out[:, :, c] = v.reshape(H * s, W * s)
    return siproject.coefficients(out, size=(W, H), generator="cubic", method="min-error")


def measure(a):
    W = H = a.res
    rows = []
    for scene in a.scenes.split():
        truth = siproject.Reference(
            siproject.read_image(need(render_path(a.work, scene, a.res, a.ref_factor, "regular", 0))),
            border=a.border)
        t = time.perf_counter()
        k = siproject.coefficients(need(render_path(a.work, scene, a.res, "1", "regular", 0)),
                                   size=(W, H), generator="tent", method="conventional")
        rows.append(dict(scene=scene, rays=1.0, method="conventional tent (regular)",
                         l2=truth.l2_error(k), seconds=time.perf_counter() - t, note=""))
        for rays, factor in DENSITIES:
            path = need(render_path(a.work, scene, a.res, factor, "sobol", a.seed))
            for rule in RULES:
                t = time.perf_counter()
                note, l2 = "", math.nan
                try:
                    k = siproject.coefficients(path, size=(W, H), generator="cubic",
                                               method="min-error", rule=rule)
                    l2 = truth.l2_error(k)
                    if rule == "variational":
                        note = "lambda %.3g" % k.report["lambda"]
                except (ValueError, OSError) as e:
                    note = str(e).splitlines()[0][:120]
                rows.append(dict(scene=scene, rays=float(rays), method=rule, l2=l2,
                                 seconds=time.perf_counter() - t, note=note))
            values = siproject.read_image(path)
            values = values.reshape(-1, values.shape[-1]).astype(np.float64)
            positions = siproject.sample_positions("sobol", seed=a.seed, size=(W, H),
                                                   rays_per_pixel=float(factor) ** 2)
            if len(positions) != len(values):
                sys.exit(f"compare_sparse.py: {path}: {len(values)} rays, the pattern has "
                         f"{len(positions)}")
            for kind in ("linear", "cubic"):
                t = time.perf_counter()
                k = griddata_coefficients(positions, values, W, H, kind)
                rows.append(dict(scene=scene, rays=float(rays), method="griddata " + kind,
                                 l2=truth.l2_error(k), seconds=time.perf_counter() - t, note=""))
            print(f"compare_sparse.py: {scene} at {rays} rays per pixel done", file=sys.stderr)
    return rows


def write(a, rows):
    os.makedirs(a.report, exist_ok=True)
    with open(os.path.join(a.report, "sparse.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [f"# Fewer rays than pixels ({a.res}^2, reference factor {a.ref_factor}, sobol seed "
             f"{a.seed}, border {a.border})", ""]
    for scene in a.scenes.split():
        sr = [r for r in rows if r["scene"] == scene]
        tent = next(r["l2"] for r in sr if r["method"].startswith("conventional"))
        lines += [f"## {scene}", "", f"Conventional tent at 1 ray per pixel (regular): L2 {tent:.6f}.",
                  "", "| rays per pixel | method | L2 | / tent at 1 | seconds | note |",
                  "| --- | --- | --- | --- | --- | --- |"]
        for r in sr:
            if r["method"].startswith("conventional"):
                continue
            lines.append(f"| {r['rays']:g} | {r['method']} | {r['l2']:.6f} | {r['l2'] / tent:.3f} | "
                         f"{r['seconds']:.2f} | {r['note']} |")
        v = [r for r in sr if r["method"] == "variational" and r["rays"] == 0.5]
        if v:
            ratio = v[0]["l2"] / tent
            lines += ["", f"Goal (variational at 0.5 ray per pixel within 10 % of the tent at 1): "
                          f"ratio {ratio:.3f}, {'met' if ratio <= 1.1 else 'missed'}."]
        lines.append("")
    with open(os.path.join(a.report, "sparse.md"), "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", required=True)
    p.add_argument("--report", required=True)
    p.add_argument("--scenes", default="objects")
    p.add_argument("--res", type=int, default=128)
    p.add_argument("--ref-factor", default="16")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--border", type=float, default=2.0)
    a = p.parse_args()
    write(a, measure(a))


if __name__ == "__main__":
    main()
