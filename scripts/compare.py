#!/usr/bin/env python3
"""compare.py: accuracy against speed for every scene and method (make compare).

    compare.py --work DIR --report DIR [--scenes "checker objects ..."] [--res 256]
               [--factors "1 2 3 4 6 8"] [--ref-factor 32] [--aa "am1-r2 ... am2-r4"]
               [--method NAME='siproject options' ...] [--border 4]
               [--cutoffs "0.125 0.25"] [--show-factor 4] [--repeats 3]
               [--label full|quick]

For every scene (scenes/SCENE.pov):
  renders    make's render target (scripts/renders.py: make render OUT=WORK
             SCENE=... RES=... FACTOR=..., the Makefile's one staleness
             rule), antialiasing off, at every FACTOR (RES * FACTOR pixels per
             axis) and at REF_FACTOR (the reference); POV-Ray's wall time
             (start-up and parse included) and +GS statistics as
             scripts/render.sh records them beside the render (NAME.stats):
             the smallest of up to REPEATS runs for renders under 3 s, which
             stop early once two runs agree within 5 %;
  baseline   POV-Ray's own antialiasing at the final size: +A0.0 (threshold 0,
             so every pixel is supersampled) with +AM1 (n x n grid plus the
             centre ray, n = depth) or +AM2 (recursive corner subdivision,
             a (2^(R-1)+1)^2 grid per pixel), -J: make render FACTOR=1
             POVOPTS=... in WORK/pov-aa/AA/; render.sh forces -A but passes
             these after it, and POV-Ray takes the last option given;
  methods    every method (the Makefile's METHOD_OPTS_*, siproject's options)
             on every render through the Python module siproject, in this
             process (subprocesses only for make's renders): the display EXR, the
             coefficient file (one per distinct approximation: methods that
             differ only in --display share f_app), and the projection's time
             (the render read, projected and resampled), the smallest of
             REPEATS runs;
  reference  display: the reference render's pixel averages (box,
             conventional, at the final size);
  measures   simetrics' measures, by the module (each reference and render
             read once) per (scene, factor, method): hp shares at CUTOFFS, rms
             and psnr against the reference display (border BORDER), overshoot
             against the method's own input (the baseline: the reference
             render), continuous L2 error of f_app against the reference
             render (a siproject.Reference: the render acquired once per
             generator) or, for the zone plate, its closed form. The
             baseline's f_app is piecewise constant (box).

Every other artefact lives in WORK with a JSON sidecar holding what it was
made from (file digests, options, the module's digest) and its timings; it is
remade only when that changes. Then scripts/report_compare.py writes the report folder (built in a
temporary folder and renamed into place). Any failure: a message on stderr,
exit status 1 (2 for usage), no partial file.
"""
import argparse
import hashlib
import json
import math
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time

import numpy as np

try:
    import siproject
except ImportError as e:
    sys.exit(f"compare: the Python module siproject is missing ({e}): run make build, which builds it "
             f"and puts it on .venv's path")
from atomic import write_atomic  # noqa: E402
from renders import RenderError, make_render, stats_path  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PROG = "compare"

# The Makefile passes its METHOD_OPTS_* (--method NAME=OPTIONS); these are the
# same, for running the script by hand.
DEFAULT_METHODS = [
    ("box", "--generator box --method conventional --display centred"),
    ("conv-tent", "--generator tent --method conventional --display centred"),
    ("me-tent", "--generator tent --method min-error --display centred"),
    ("mitchell", "--generator mitchell --method conventional --display centred"),
    ("me-cubic", "--generator cubic --method min-error --display centred"),
    ("me-tent-2x2", "--generator tent --method min-error --display 2x2"),
    ("me-cubic-2x2", "--generator cubic --method min-error --display 2x2"),
]
AA_RE = re.compile(r"^am([12])-r([1-9])$")
SCHEMA = 1  # bump to redo every step after a change of what the sidecars hold


class CompareError(Exception):
    pass


def log(message):
    print(f"{PROG}: {message}", file=sys.stderr, flush=True)


def say(message):
    print(message, flush=True)


def rel(path):
    p = os.path.abspath(path)
    return os.path.relpath(p, ROOT) if p.startswith(ROOT + os.sep) else p


# ---- files -----------------------------------------------------------------------

def write_json(path, obj):
    write_atomic(path, json.dumps(obj, indent=1, sort_keys=True, allow_nan=False) + "\n")


def read_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def temp_name(path, suffix):
    """A hidden temporary name beside PATH ending in SUFFIX (siproject wants .exr)."""
    d, b = os.path.split(path)
    return os.path.join(d, f".{b}.{os.getpid()}.tmp{suffix}")


def remove(*paths):
    for p in paths:
        try:
            os.unlink(p)
        except FileNotFoundError:
            pass


def same_pixels(a, b):
    """Two EXRs with the same channels, pixels and sis: metadata (the keys
    both have, but for sis:input): a redone step that made the same image keeps the old file, so
    that what depends on the file's digest is not redone for nothing."""
    if not (os.path.isfile(a) and os.path.isfile(b)):
        return False
    import OpenEXR
    try:
        with OpenEXR.File(a) as fa, OpenEXR.File(b) as fb:
            ha = {k: str(v) for k, v in fa.header().items() if k.startswith("sis:") and k != "sis:input"}
            hb = {k: str(v) for k, v in fb.header().items() if k.startswith("sis:") and k != "sis:input"}
            # A key only one build writes (a new feature's) does not make the images differ.
            if any(ha[k] != hb[k] for k in ha.keys() & hb.keys()):
                return False
            ca, cb = fa.channels(), fb.channels()
            if sorted(ca) != sorted(cb):
                return False
            for k in ca:
                pa, pb = ca[k].pixels, cb[k].pixels
                if pa.dtype != pb.dtype or pa.shape != pb.shape or pa.tobytes() != pb.tobytes():
                    return False
            return True
    except Exception:  # unreadable: not the same
        return False


def settle(tmp, final):
    """Moves TMP to FINAL unless FINAL already holds the same image."""
    if same_pixels(tmp, final):
        remove(tmp)
    else:
        os.replace(tmp, final)


class Digests:
    """SHA-256 of files, kept across runs by (size, mtime) in WORK/.digests.json."""

    def __init__(self, path):
        self.path = path
        self.cache = read_json(path) or {}
        self.dirty = False

    def __call__(self, path):
        p = os.path.abspath(path)
        st = os.stat(p)
        key = [st.st_size, st.st_mtime_ns]
        hit = self.cache.get(p)
        if hit and hit[0] == key:
            return hit[1]
        h = hashlib.sha256()
        with open(p, "rb") as f:
            for block in iter(lambda: f.read(1 << 22), b""):
                h.update(block)
        digest = h.hexdigest()[:20]
        self.cache[p] = [key, digest]
        self.dirty = True
        return digest

    def save(self):
        if self.dirty:
            live = {k: v for k, v in self.cache.items() if os.path.exists(k)}
            write_json(self.path, live)
            self.dirty = False


def fresh(sidecar, stamp, outputs):
    """The step's sidecar records STAMP and every output exists."""
    info = read_json(sidecar)
    if not info or info.get("stamp") != stamp:
        return None
    if not all(os.path.isfile(o) for o in outputs):
        return None
    return info


# ---- processes -------------------------------------------------------------------

def load_average():
    try:
        with open("/proc/loadavg") as f:
            return float(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None


TOTAL_RE = re.compile(r"total ([0-9.]+) s")


def module_keywords(opts):
    """siproject's options (the Makefile's METHOD_OPTS_*) as the module's
    keywords: --name VALUE as name=VALUE, a lone --flag as flag=True."""
    out, i = {}, 0
    while i < len(opts):
        o = opts[i]
        if not o.startswith("--"):
            raise CompareError(f"method options {shlex.join(opts)}: '{o}' is not an option")
        key = o[2:].replace("-", "_")
        if i + 1 < len(opts) and not opts[i + 1].startswith("--"):
            value = opts[i + 1]
            out[key] = float(value) if key in ("density",) else value
            i += 2
        else:
            out[key] = True
            i += 1
    return out


def engine(call, what, *args, **kwargs):
    """A call into the module, its errors as CompareError naming WHAT."""
    try:
        return call(*args, **kwargs)
    except (ValueError, OSError, RuntimeError) as e:
        raise CompareError(f"{what}: {e}")


# ---- configuration -------------------------------------------------------------------

def parse_size(text):
    m = re.fullmatch(r"([1-9][0-9]*)(?:x([1-9][0-9]*))?", text)
    if not m:
        raise CompareError(f"--res {text}: expected N or WxH, positive integers")
    w = int(m.group(1))
    return w, int(m.group(2) or w)


def parse_args(argv):
    p = argparse.ArgumentParser(prog="compare.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--work", required=True, help="folder of renders, images and measures (kept)")
    p.add_argument("--report", required=True, help="report folder (replaced as a whole)")
    p.add_argument("--scenes", default="checker objects edges hdr zoneplate")
    p.add_argument("--scenedir", default=os.path.join(ROOT, "scenes"))
    p.add_argument("--res", default="256")
    p.add_argument("--factors", default="1 2 3 4 6 8")
    p.add_argument("--ref-factor", type=float, default=32)
    p.add_argument("--aa", default="am1-r2 am1-r3 am1-r4 am2-r1 am2-r2 am2-r3 am2-r4",
                   help="POV-Ray antialiasing baselines: amM-rR = +AM<M> +R<R> +A0.0 -J")
    p.add_argument("--method", action="append", default=[], metavar="NAME=OPTIONS",
                   help="a method and its siproject options (repeatable; default: the Makefile's)")
    p.add_argument("--border", type=int, default=4, help="output pixels left out along each edge")
    p.add_argument("--cutoffs", default="0.125 0.25")
    p.add_argument("--show-factor", type=float, default=None,
                   help="factor of the images shown in the report (default: 4, or the nearest)")
    p.add_argument("--repeats", type=int, default=3, help="timing runs (smallest kept)")
    p.add_argument("--zp-nyquist", type=float, default=0.7)
    p.add_argument("--label", default="full", help="names the configuration in the report")
    a = p.parse_args(argv)

    cfg = argparse.Namespace()
    cfg.work = os.path.abspath(a.work)
    cfg.report = os.path.abspath(a.report)
    cfg.label = a.label
    cfg.scenedir = os.path.abspath(a.scenedir)
    cfg.scenes = a.scenes.split()
    if not cfg.scenes:
        raise CompareError("--scenes: no scene given")
    for s in cfg.scenes:
        if not os.path.isfile(os.path.join(cfg.scenedir, s + ".pov")):
            have = sorted(f[:-4] for f in os.listdir(cfg.scenedir) if f.endswith(".pov"))
            raise CompareError(f"no scene {rel(os.path.join(cfg.scenedir, s + '.pov'))}; scenes: {' '.join(have)}")
    cfg.w, cfg.h = parse_size(a.res)
    cfg.res_tag = str(cfg.w) if cfg.w == cfg.h else f"{cfg.w}x{cfg.h}"
    try:
        cfg.factors = [float(f) for f in a.factors.split()]
        cfg.cutoffs = [float(c) for c in a.cutoffs.split()]
    except ValueError as e:
        raise CompareError(f"--factors/--cutoffs: {e}")
    if not cfg.factors or any(not (f > 0 and math.isfinite(f)) for f in cfg.factors):
        raise CompareError(f"--factors '{a.factors}': expected positive numbers")
    cfg.factors = sorted(set(cfg.factors))
    if not (a.ref_factor > max(cfg.factors)):
        raise CompareError(f"--ref-factor {a.ref_factor:g} must exceed the largest factor {max(cfg.factors):g}")
    cfg.ref_factor = a.ref_factor
    cfg.aa = a.aa.split()
    for name in cfg.aa:
        if not AA_RE.match(name):
            raise CompareError(f"--aa {name}: expected amM-rR, M = 1 or 2, R = 1..9")
    methods = []
    for spec in a.method:
        name, eq, opts = spec.partition("=")
        if not eq or not name or not opts.strip():
            raise CompareError(f"--method '{spec}': expected NAME=OPTIONS")
        methods.append((name.strip(), opts.strip()))
    cfg.methods = methods or list(DEFAULT_METHODS)
    names = [m for m, _ in cfg.methods]
    if len(set(names)) != len(names):
        raise CompareError(f"--method: a name given twice: {' '.join(names)}")
    cfg.method_opts = dict(cfg.methods)
    cfg.method_names = names
    if a.border < 0 or 2 * a.border >= min(cfg.w, cfg.h):
        raise CompareError(f"--border {a.border} leaves no pixel of {cfg.w} x {cfg.h}")
    cfg.border = a.border
    if a.repeats < 1:
        raise CompareError("--repeats must be at least 1")
    cfg.repeats = a.repeats
    sf = a.show_factor if a.show_factor is not None else 4.0
    cfg.show_factor = min(cfg.factors, key=lambda f: (abs(math.log(f / sf)), -f))
    cfg.zp_nyquist = a.zp_nyquist
    # As the Makefile: ZP_K = ZP_NYQUIST * pi * output width, printed %.6f.
    cfg.zp_k = "%.6f" % (a.zp_nyquist * math.pi * cfg.w)
    return cfg


def fmt_factor(f):
    return f"{f:g}"


def render_size(cfg, factor):
    return int(cfg.w * factor + 0.5), int(cfg.h * factor + 0.5)


def approximation_key(opts):
    """siproject options without --display: methods with the same key share f_app."""
    words = shlex.split(opts)
    out, i = [], 0
    while i < len(words):
        if words[i] == "--display":
            i += 2
            continue
        if words[i].startswith("--display="):
            i += 1
            continue
        out.append(words[i])
        i += 1
    return " ".join(out)


def aa_options(name):
    m = AA_RE.match(name)
    return ["+A0.0", f"+AM{m.group(1)}", f"+R{m.group(2)}", "-J"]


def aa_label(name):
    m = AA_RE.match(name)
    return f"POV-Ray +AM{m.group(1)} +R{m.group(2)}"


# ---- the steps -----------------------------------------------------------------------

class Pipeline:
    def __init__(self, cfg, tools):
        self.cfg = cfg
        self.tools = tools  # {"module_sha": the Python module's digest}
        self.digest = Digests(os.path.join(cfg.work, ".digests.json"))
        self.counts = {"render": 0, "project": 0, "measure": 0, "reused": 0}
        self.images = []  # (path, array): the last few read, newest last
        self.truth = None  # (path, siproject.Reference): the scene's reference render
        # Representative method of each approximation (the first with its key).
        self.rep = {}
        for name, opts in cfg.methods:
            self.rep.setdefault(approximation_key(opts), name)

    def close(self):
        self.digest.save()

    # -- renders --
    def render(self, scene, name, factor, povopts, out):
        """The render of SCENE made by make (renders.make_render: the
        Makefile's render target, its one staleness rule) in OUT, with
        render.sh's statistics: POV-Ray's wall time (the smallest of up to
        REPEATS runs for renders under 3 s) and its +GS statistics."""
        cfg = self.cfg
        try:
            path, stats, made = make_render(out, scene, (cfg.w, cfg.h), fmt_factor(factor), povopts,
                                            scenedir=cfg.scenedir,
                                            zp_nyquist=cfg.zp_nyquist, repeats=cfg.repeats)
        except RenderError as e:
            raise CompareError(str(e))
        width, height = render_size(cfg, factor)
        if "wall_s" not in stats:
            raise CompareError(f"{rel(stats_path(path))}: no wall_s")
        if "pixels" in stats:
            rays = (stats["pixels"] + stats.get("samples", 0)) / (width * height)
        else:
            rays = None
        info = {"file": os.path.relpath(path, cfg.work), "width": width, "height": height,
                "wall_s": stats["wall_s"], "wall_runs": stats.get("wall_runs", [stats["wall_s"]]),
                "primary_rays_per_pixel": rays, "digest": self.digest(path),
                **{k: stats[k] for k in ("parse_s", "trace_s") if k in stats}}
        if "pixels" in stats:
            info["pixels_traced"] = stats["pixels"]
            info["samples"] = stats.get("samples", 0)
        if made:
            self.counts["render"] += 1
            say(f"         {name}: {info['wall_s']:.2f} s wall ({len(info['wall_runs'])} run(s)), "
                f"{'%.2f' % rays if rays is not None else '?'} primary rays per pixel")
        else:
            self.counts["reused"] += 1
        return path, info

    def factor_render(self, scene, factor):
        """RES x FACTOR rays per axis, antialiasing off: WORK/render/."""
        return self.render(scene, "f" + fmt_factor(factor), factor, [], self.cfg.work)

    def aa_render(self, scene, aa):
        """POV-Ray's antialiasing at the final size: a render of factor 1 with
        its options, in a folder of its own (WORK/pov-aa/AA/render/)."""
        return self.render(scene, "aa-" + aa, 1, aa_options(aa), os.path.join(self.cfg.work, "pov-aa", aa))

    # -- projections --
    def project(self, scene, factor, method, render, rinfo):
        """METHOD on RENDER by the Python module, in this process: the float
        display EXR, the coefficient file of its approximation (one per
        distinct approximation), and the time of the projection (the render
        read, projected and resampled: what siproject -v calls total, short of
        the write), the smallest of REPEATS runs."""
        cfg = self.cfg
        opts = shlex.split(cfg.method_opts[method])
        d = os.path.join(cfg.work, scene, "f" + fmt_factor(factor))
        exr = os.path.join(d, method + ".exr")
        rep = self.rep[approximation_key(cfg.method_opts[method])] == method
        coeffs = os.path.join(d, method + ".coeffs.exr") if rep else None
        side = os.path.join(d, method + ".json")
        size = f"{cfg.w}x{cfg.h}"
        stamp = {"schema": SCHEMA, "render": rinfo["digest"], "engine": self.tools["module_sha"],
                 "size": size, "options": opts, "coeffs": rep}
        outputs = [exr] + ([coeffs] if coeffs else [])
        info = fresh(side, stamp, outputs)
        if info:
            self.counts["reused"] += 1
            return info
        os.makedirs(d, exist_ok=True)
        keywords = module_keywords(opts)
        what = f"{method} on {rel(render)}"
        t_exr = temp_name(exr, ".exr")
        t_coeffs = temp_name(coeffs, ".exr") if coeffs else None
        # The coefficients, then the display from them: what project() does
        # (the same image, bit for bit), with the coefficients kept.
        kept = {k: v for k, v in keywords.items() if k not in ("display", "clamp")}
        shown = {k: v for k, v in keywords.items() if k in ("display", "clamp")}
        try:
            totals, loads = [], []
            for k in range(cfg.repeats):
                loads.append(load_average())
                t0 = time.perf_counter()
                approximation = engine(siproject.coefficients, what, render, size=size, **kept)
                if shown.get("clamp") == "local":  # needs the samples: the whole projection again
                    image = engine(siproject.project, what, render, size=size, **keywords)
                else:
                    image = engine(approximation.resample, what, size, **shown)
                totals.append(time.perf_counter() - t0)
            engine(siproject.write_image, what, t_exr, image)
            if coeffs:
                engine(approximation.save, what, t_coeffs)
            settle(t_exr, exr)
            if coeffs:
                settle(t_coeffs, coeffs)
        finally:
            remove(t_exr, *([t_coeffs] if t_coeffs else []))
        info = {"stamp": stamp, "project_s": min(totals), "project_runs": totals, "load_before": loads,
                "digest": self.digest(exr), "coeffs_digest": self.digest(coeffs) if coeffs else None,
                "command": shlex.join(["siproject", rel(render), "--size", size] + opts)}
        write_json(side, info)
        self.counts["project"] += 1
        say(f"project  {scene:<10} f{fmt_factor(factor):<7} {method:<13} {min(totals):.3f} s")
        return info

    def box_of(self, scene, name, src, srcinfo, size, coeffs_too):
        """SRC through box (conventional), by the module: the reference
        display at the output size, or the baseline's coefficient file at
        its own size (SIZE None)."""
        cfg = self.cfg
        d = os.path.join(cfg.work, scene, "ref" if name == "ref" else "aa")
        out = os.path.join(d, (name + ".display.exr") if name == "ref" else (name + ".coeffs.exr"))
        side = out[:-4] + ".json"
        keywords = dict(generator="box", method="conventional")
        stamp = {"schema": SCHEMA, "input": srcinfo["digest"], "engine": self.tools["module_sha"],
                 "size": size, "coefficients": coeffs_too}
        info = fresh(side, stamp, [out])
        if info:
            self.counts["reused"] += 1
            return out, info
        os.makedirs(d, exist_ok=True)
        tmp = temp_name(out, ".exr")
        what = f"box on {rel(src)}"
        try:
            if coeffs_too:
                engine(lambda: siproject.coefficients(src, factor=1, **keywords).save(tmp), what)
            else:
                engine(siproject.write_image, what, tmp,
                       engine(siproject.project, what, src, size=size, display="centred", **keywords))
            settle(tmp, out)
        finally:
            remove(tmp)
        info = {"stamp": stamp, "digest": self.digest(out)}
        write_json(side, info)
        self.counts["project"] += 1
        say(f"project  {scene:<10} {name:<8} box {'coefficients' if coeffs_too else 'pixel averages'}")
        return out, info

    # -- measures --
    def image(self, path):
        """A finite image as a float32 array, read once while it is among the
        last few asked for (the references and renders serve many measures)."""
        if self.truth and self.truth[0] == path:
            return self.truth[1].array
        for i, (p, a) in enumerate(self.images):
            if p == path:
                self.images.append(self.images.pop(i))
                return a
        a = siproject.read_image(path)
        if not np.isfinite(a).all():
            bad = np.argwhere(~np.isfinite(a))[0]
            raise CompareError(f"{rel(path)}: non-finite value (NaN or Inf) at x {bad[1]}, y {bad[0]}, "
                               f"channel {bad[2]}")
        self.images.append((path, a))
        del self.images[:-4]
        return a

    def reference(self, path):
        """The reference render at PATH kept for the L2 errors against it (the
        last one asked for)."""
        if not (self.truth and self.truth[0] == path):
            self.truth = None
            self.truth = (path, siproject.Reference(self.image(path), border=self.cfg.border))
        return self.truth[1]

    def measure(self, scene, key, image, image_digest, refdisp, refdisp_digest, inp, inp_digest,
                coeffs=None, coeffs_digest=None, truth=None, truth_digest=None, zoneplate=False,
                factor=None):
        """simetrics' measures of IMAGE, computed here by the module: hp shares
        at the cutoffs, rms and psnr against REFDISP, overshoot against INP,
        and the continuous L2 error of COEFFS against TRUTH or the zone plate."""
        cfg = self.cfg
        out = os.path.join(cfg.work, scene, key + ".metrics.json")
        use_zp = bool(coeffs) and zoneplate
        stamp = {"schema": SCHEMA, "measures": self.tools["module_sha"], "border": cfg.border,
                 "cutoffs": cfg.cutoffs, "factor": factor,
                 "image": image_digest, "reference": refdisp_digest, "input": inp_digest,
                 "coeffs": coeffs_digest if coeffs else None,
                 "truth": truth_digest if (coeffs and not use_zp) else None,
                 "zoneplate": [cfg.zp_k, self.zp_spp()] if use_zp else None}
        info = fresh(out, stamp, [])
        if info:
            self.counts["reused"] += 1
            return info["metrics"]
        t0 = time.perf_counter()
        try:
            img = self.image(image)
            ref = self.image(refdisp)
            src = self.image(inp)
            if ref.shape != img.shape:
                raise CompareError(f"{rel(refdisp)} is {ref.shape}, {rel(image)} {img.shape}")
            h, w = img.shape[:2]
            if factor is not None and (round(src.shape[1] / factor) != w or round(src.shape[0] / factor) != h):
                raise CompareError(f"{rel(inp)} is {src.shape[1]} x {src.shape[0]}: at factor {factor} "
                                   f"it does not cover {rel(image)} ({w} x {h})")
            metrics = {"width": w, "height": h, "channels": img.shape[2]}
            for c, share in zip(cfg.cutoffs, siproject.highpass_share(img, cfg.cutoffs)):
                metrics["hp_" + format(c, "g")] = share
            metrics["rms"] = siproject.rms_difference(img, ref, border=cfg.border)
            metrics["psnr"] = siproject.psnr(img, ref, peak=1.0, border=cfg.border)
            metrics["overshoot"] = siproject.overshoot(img, src, border=cfg.border)
            if coeffs:
                k = siproject.load(coeffs)
                l2 = (siproject.l2_error(k, zoneplate=float(cfg.zp_k), samples_per_pixel=self.zp_spp(),
                                         border=cfg.border) if use_zp
                      else self.reference(truth).l2_error(k))
                metrics["continuous"] = {"l2_error": l2}
        except (ValueError, OSError, RuntimeError) as e:
            raise CompareError(f"measures of {rel(image)}: {e}")
        metrics = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in metrics.items()}
        write_json(out, {"stamp": stamp, "metrics": metrics})
        self.counts["measure"] += 1
        say(f"measure  {scene:<10} {key:<22} {time.perf_counter() - t0:.1f} s")
        return metrics

    def zp_spp(self):
        return int(min(32, max(8, round(self.cfg.ref_factor))))


def snapshot_tools(cfg):
    """The digest of the engine the steps run on (the Python module), and
    POV-Ray present."""
    tools = {}
    with open(siproject._core.__file__, "rb") as f:
        tools["module_sha"] = hashlib.sha256(f.read()).hexdigest()[:16]
    if shutil.which("povray") is None:
        raise CompareError("povray not found on PATH (run scripts/setup.sh)")
    return tools

def number(x):
    return x if isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) else None


def row_from(metrics, cutoffs):
    row = {}
    for c in cutoffs:
        key = "hp_" + format(c, "g")
        row[key] = number(metrics.get(key))
    row["rms"] = number(metrics.get("rms"))
    row["psnr"] = number(metrics.get("psnr"))
    ov = metrics.get("overshoot") or {}
    for k in ("max_overshoot", "max_undershoot", "pixels_out_of_range", "negative_pixels",
              "negative_energy", "min", "max", "pixels"):
        row["ov_" + k if k in ("min", "max", "pixels") else k] = number(ov.get(k))
    cont = metrics.get("continuous") or {}
    row["l2"] = number(cont.get("l2_error"))
    return row


def run_pipeline(cfg, pipe):
    rows, refs = [], {}
    for scene in cfg.scenes:
        # Renders first (the expensive part), the reference last among them.
        renders = {f: pipe.factor_render(scene, f) for f in cfg.factors}
        aas = {a: pipe.aa_render(scene, a) for a in cfg.aa}
        ref, refinfo = pipe.factor_render(scene, cfg.ref_factor)
        refdisp, refdinfo = pipe.box_of(scene, "ref", ref, refinfo, f"{cfg.w}x{cfg.h}", False)
        refs[scene] = {"render": os.path.relpath(ref, cfg.work), "render_s": refinfo["wall_s"],
                       "width": refinfo["width"], "height": refinfo["height"],
                       "display": os.path.relpath(refdisp, cfg.work)}
        zp = scene == "zoneplate"
        for f in cfg.factors:
            render, rinfo = renders[f]
            for method in cfg.method_names:
                pinfo = pipe.project(scene, f, method, render, rinfo)
                d = os.path.join(cfg.work, scene, "f" + fmt_factor(f))
                rep = pipe.rep[approximation_key(cfg.method_opts[method])]
                coeffs = os.path.join(d, rep + ".coeffs.exr") if rep == method else None
                m = pipe.measure(scene, f"f{fmt_factor(f)}/{method}", os.path.join(d, method + ".exr"),
                                 pinfo["digest"], refdisp, refdinfo["digest"], render, rinfo["digest"],
                                 coeffs, pinfo.get("coeffs_digest"), ref, refinfo["digest"], zp, f)
                row = {"scene": scene, "kind": "method", "method": method, "factor": f,
                       "rays_per_pixel": f * f, "render_s": rinfo["wall_s"],
                       "render_trace_s": rinfo.get("trace_s"),
                       "project_s": pinfo["project_s"], "total_s": rinfo["wall_s"] + pinfo["project_s"],
                       "image": os.path.relpath(os.path.join(d, method + ".exr"), cfg.work),
                       "render": os.path.relpath(render, cfg.work),
                       "l2_shared_with": None if rep == method else rep,
                       "options": cfg.method_opts[method]}
                row.update(row_from(m, cfg.cutoffs))
                if zp and f == cfg.show_factor and coeffs:
                    # Cross-check: the same error against the reference render instead of the closed form.
                    m2 = pipe.measure(scene, f"f{fmt_factor(f)}/{method}.truth-render",
                                      os.path.join(d, method + ".exr"), pinfo["digest"], refdisp,
                                      refdinfo["digest"], render, rinfo["digest"], coeffs,
                                      pinfo.get("coeffs_digest"), ref, refinfo["digest"], False, f)
                    row["l2_against_render"] = number((m2.get("continuous") or {}).get("l2_error"))
                rows.append(row)
        for a in cfg.aa:
            render, rinfo = aas[a]
            coeffs, cinfo = pipe.box_of(scene, a, render, rinfo, None, True)
            m = pipe.measure(scene, f"aa/{a}", render, rinfo["digest"], refdisp, refdinfo["digest"], ref,
                             refinfo["digest"], coeffs, cinfo["digest"], ref, refinfo["digest"], zp)
            row = {"scene": scene, "kind": "pov-aa", "method": "pov-" + a, "factor": None,
                   "rays_per_pixel": rinfo.get("primary_rays_per_pixel"), "render_s": rinfo["wall_s"],
                   "render_trace_s": rinfo.get("trace_s"),
                   "project_s": 0.0, "total_s": rinfo["wall_s"],
                   "image": os.path.relpath(render, cfg.work), "render": os.path.relpath(render, cfg.work),
                   "l2_shared_with": None, "options": " ".join(aa_options(a)), "label": aa_label(a)}
            row.update(row_from(m, cfg.cutoffs))
            rows.append(row)
        pipe.digest.save()
    for r in rows:
        if r["l2_shared_with"]:
            src = next(x for x in rows if x["scene"] == r["scene"] and x["factor"] == r["factor"]
                       and x["method"] == r["l2_shared_with"])
            r["l2"] = src["l2"]
            if "l2_against_render" in src:
                r["l2_against_render"] = src["l2_against_render"]
    return rows, refs


def on_term(signum, frame):
    raise SystemExit(128 + signum)  # so that the temporary files are removed


def main(argv):
    signal.signal(signal.SIGTERM, on_term)
    try:
        cfg = parse_args(argv)
    except CompareError as e:
        log(str(e))
        return 2
    t_start = time.time()
    pipe = None
    try:
        os.makedirs(cfg.work, exist_ok=True)
        tools = snapshot_tools(cfg)
        pipe = Pipeline(cfg, tools)
        say(f"compare ({cfg.label}): {len(cfg.scenes)} scene(s), {cfg.w} x {cfg.h}, factors "
            f"{' '.join(map(fmt_factor, cfg.factors))}, reference factor {fmt_factor(cfg.ref_factor)}, "
            f"{len(cfg.method_names)} methods, {len(cfg.aa)} POV-Ray baselines; work {rel(cfg.work)}")
        rows, refs = run_pipeline(cfg, pipe)
        pipe.close()
        meta = {
            "label": cfg.label, "scenes": cfg.scenes, "width": cfg.w, "height": cfg.h,
            "factors": cfg.factors, "ref_factor": cfg.ref_factor, "aa": cfg.aa,
            "aa_labels": {("pov-" + a): aa_label(a) for a in cfg.aa},
            "methods": cfg.method_names, "method_options": cfg.method_opts,
            "shares_f_app": {m: pipe.rep[approximation_key(o)] for m, o in cfg.methods
                             if pipe.rep[approximation_key(o)] != m},
            "border": cfg.border, "cutoffs": cfg.cutoffs, "show_factor": cfg.show_factor,
            "zp_k": float(cfg.zp_k), "zp_samples_per_pixel": pipe.zp_spp(), "repeats": cfg.repeats,
            "repeat_below_s": 3.0,  # scripts/render.sh's RENDER_REPEATS
            "tools": {k: v for k, v in tools.items() if k.endswith("_sha")},
            "povray": povray_version(), "nproc": os.cpu_count(),
            "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
            "steps": dict(pipe.counts), "pipeline_s": time.time() - t_start,
            "references": refs,
        }
        sys.path.insert(0, HERE)
        import report_compare
        report_compare.build(cfg.report, cfg.work, meta, rows)
        say(f"compare: report {rel(os.path.join(cfg.report, 'index.html'))} "
            f"({pipe.counts['render']} renders, {pipe.counts['project']} projections, "
            f"{pipe.counts['measure']} measures made, {pipe.counts['reused']} reused; "
            f"{time.time() - t_start:.0f} s)")
        return 0
    except CompareError as e:
        log("error: " + str(e))
        return 1
    except KeyboardInterrupt:
        log("interrupted")
        return 130


def povray_version():
    try:
        r = subprocess.run(["povray", "--version"], capture_output=True, text=True, stdin=subprocess.DEVNULL)
        for line in (r.stdout + r.stderr).splitlines():
            if line.startswith("POV-Ray"):
                return line.strip()
    except OSError:
        pass
    return "?"


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
