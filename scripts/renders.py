"""The studies' renders, made by make (the Makefile's render target and its one
staleness rule: a render is redone when its scene, scenes/povray.ini, size,
factor or POV-Ray options change).

    path, stats, made = make_render(out, scene, res, factor, ...)

runs `make -C ROOT render OUT=out SCENE=scene RES=res FACTOR=factor ...` with
the binaries given (SIPROJECT, SIMETRICS, SIRAYS: nothing is built) and
returns the render's path (named as the Makefile names it), its statistics
(OUT/render/NAME.stats, written by scripts/render.sh when POV-Ray rendered
it: wall_s, wall_runs, parse_s, trace_s, pixels, samples; for a pattern's
render the sums over its mesh bands, with rays, mesh_s, mesh_bytes and
bands) and whether make rendered it now.
"""
import math
import os
import subprocess

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


class RenderError(Exception):
    pass


def res_tag(res):
    """The Makefile's RES_TAG: N for a square, WxH otherwise."""
    w, h = (res, res) if isinstance(res, int) else res
    return str(w) if w == h else f"{w}x{h}"


def render_path(out, scene, res, factor, samples="regular", seed=0):
    """OUT/render/SCENE-RES-fFACTOR[-SAMPLES-sSEED].exr, FACTOR as given to make."""
    tag = "" if samples == "regular" else f"-{samples}-s{seed}"
    return os.path.join(out, "render", f"{scene}-{res_tag(res)}-f{factor}{tag}.exr")


def zp_k(res, nyquist=0.7):
    """The zone plate's chirp rate for a frame RES pixels wide, as the
    Makefile declares it (ZP_K: NYQUIST * pi * RES, 6 decimals)."""
    return float(f"{nyquist * math.pi * res:.6f}")


def stats_path(render):
    return render[:-len(".exr")] + ".stats"


def read_stats(path):
    """NAME VALUE lines: numbers (wall_runs: a list)."""
    stats = {}
    try:
        with open(path) as f:
            for line in f:
                words = line.split()
                if not words:
                    continue
                values = []
                for w in words[1:]:
                    try:
                        values.append(float(w) if any(c in w for c in ".eE") else int(w))
                    except ValueError:
                        raise RenderError(f"{path}: '{line.strip()}' is not NAME NUMBER...")
                if not values:
                    continue  # POV-Ray printed no such statistic
                stats[words[0]] = values if words[0] == "wall_runs" else values[0]
    except OSError as e:
        raise RenderError(f"cannot read the render's statistics {path}: {e.strerror}")
    return stats


def make_render(out, scene, res, factor, povopts=(), samples="regular", seed=0, scenedir=None,
                zp_nyquist=None, repeats=1, jobs=1, build=None, mesh_rays=None, quiet=False):
    """The render of SCENE at RES (N or (W, H)) and FACTOR (a string or number,
    as in the render's name) made by make in OUT. Returns (path, stats, made)."""
    build = os.path.abspath(build or os.path.join(ROOT, "build"))
    w, h = (res, res) if isinstance(res, int) else res
    factor = format(factor, "g") if isinstance(factor, (int, float)) else str(factor)
    out = os.path.abspath(out)
    path = render_path(out, scene, res, factor, samples, seed)
    cmd = ["make", "-C", ROOT, "--no-print-directory", f"-j{jobs}",
           f"SIPROJECT={build}/tools/siproject", f"SIMETRICS={build}/tools/simetrics",
           f"SIRAYS={build}/tools/sirays", f"OUT={out}", f"SCENE={scene}",
           f"RES={w}x{h}" if w != h else f"RES={w}", f"FACTOR={factor}",
           f"POVOPTS={' '.join(povopts)}", f"SAMPLES={samples}", f"SEED={seed}",
           f"RENDER_REPEATS={repeats}"]
    if scenedir:
        cmd.append(f"SCENEDIR={os.path.abspath(scenedir)}")
    if zp_nyquist is not None:
        cmd.append(f"ZP_NYQUIST={zp_nyquist}")
    if mesh_rays:
        cmd.append(f"MESH_RAYS={mesh_rays}")
    cmd.append("render")
    # The caller's make (make compare ...) passes its own command line down in
    # MAKEFLAGS; this make gets only what is given here.
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL", "GNUMAKEFLAGS")}
    before = os.stat(path).st_mtime_ns if os.path.exists(path) else None
    r = subprocess.run(cmd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL if quiet else None)
    if r.returncode != 0:
        raise RenderError(f"make render SCENE={scene} RES={res_tag(res)} FACTOR={factor}"
                          f"{' SAMPLES=' + samples if samples != 'regular' else ''} failed "
                          f"with status {r.returncode} (its messages above)")
    if not os.path.isfile(path):
        raise RenderError(f"make render made no {path}")
    made = before is None or os.stat(path).st_mtime_ns != before
    return path, read_stats(stats_path(path)), made
