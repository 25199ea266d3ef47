#!/usr/bin/env python3
"""bench.py: siproject against oiiotool, splineops and the decode floor (make bench).

    bench.py [--quick] [--scene objects --render-size 8000 --out-size 1000 --runs 3]
             [--big-scene checker --big-size 16000 | --no-big] [--outdir out/bench]
             [--wait-idle S]

Input: a supersampled POV-Ray render, RENDER_SIZE x RENDER_SIZE half EXR
(antialiasing off), a make render target (scripts/renders.py: make render
OUT=OUTDIR RES=RENDER_SIZE FACTOR=1, OUTDIR/render/SCENE-SIZE-f1.exr), made
once and remade under the Makefile's one staleness rule. The default scene is objects: mostly
smooth shading that compresses like a real render (checker compresses to under
1 MB and makes decoding unrealistically cheap).

Every competitor is timed as a whole process (wall clock; peak resident set
from /usr/bin/time -v), RUNS rounds, each round running every competitor once
in turn, so that a change in the machine's load falls on all of them alike;
the table reports the median wall time and the largest peak resident set:

  decode floor   sidecode: reads the input with OpenImageIO in strips of 64
                 rows through OpenEXR's pool, in its stored sample type
                 (half: no conversion)
  decode to float  sidecode --as-float: the same through OpenImageIO's
                 conversion to float (what a reader asking for float pays)
  decode as siproject reads  sidecode --readers N (N = cores): OpenEXR
                 decoded band by band on N threads, each with a reader of
                 its own and OpenEXR's pool off, as siproject reads it, the
                 samples not used (information, not the target's floor)
  oiiotool       --resize:filter=F WxH, F = box triangle mitchell bspline lanczos3
  splineops      least-squares spline resize, degrees 1 and 3
                 (scripts/splineops_resize.py)
  siproject      min-error cubic 2x2 (default), min-error cubic centred,
                 min-error tent centred, conventional tent, box, mitchell,
                 hex-quartic 2x2 (the hexagonal lattice);
                 min-error cubic 2x2 at --threads 1 and --threads 2 (outputs
                 compared bit for bit)

plus one run of siproject min-error cubic 2x2 (and the decode floor) on a
BIG_SIZE^2 render of BIG_SCENE (peak memory at scale), and the acquisition
microbenchmark (build/tests/microbench BM_Acquisition) at 1 and 2 threads.

Scattered rays (unless --no-scatter): siproject min-error cubic 2x2 on a
render of SCENE's rays at a pattern's positions (make render
SAMPLES=SCATTER_PATTERN RES=SCATTER_RES FACTOR=SCATTER_FACTOR; 500 and 4 by
default: 2000^2 = 4 M rays, two mesh bands of 2 M, about 15 s of POV-Ray
parse at 3.7 s per million rays, made once; quick: 125 and 4) against the
regular render of the same size, RUNS rounds alternated, per sample; and,
from the render's statistics (written when make made it), each mesh band's
sirays mesh time against POV-Ray's parse of it.

Writes OUTDIR/bench.md (table, command, machine, load average, input, checks
of the targets) and OUTDIR/bench.csv (--quick: bench-quick.md and .csv), each
to a temporary name renamed at the end: never a partial file. Binaries are copied to a private folder first, so
a rebuild during the run cannot mix versions. A missing tool or a failing
competitor is an error: a message on stderr and exit status 1 (2 for usage).

--quick (make bench QUICK=1): 1000^2 render to 250^2, one run each, big
input 2000^2, for checking the whole chain in a minute.
"""
import argparse
import csv
import hashlib
import io
import json
import os
import platform
import re
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from atomic import write_atomic  # noqa: E402
from renders import RenderError, make_render, read_stats, stats_path  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PROG = "bench"

OIIO_FILTERS = ["box", "triangle", "mitchell", "bspline", "lanczos3"]

# siproject methods of the table: (name, options). Every choice spelled out,
# as the Makefile's METHOD_OPTS_* do.
SIPROJECT_METHODS = [
    ("min-error cubic 2x2", ["--generator", "cubic", "--method", "min-error", "--display", "2x2"]),
    ("min-error cubic centred", ["--generator", "cubic", "--method", "min-error", "--display", "centred"]),
    ("min-error tent centred", ["--generator", "tent", "--method", "min-error", "--display", "centred"]),
    ("conventional tent", ["--generator", "tent", "--method", "conventional", "--display", "centred"]),
    ("box", ["--generator", "box", "--method", "conventional", "--display", "centred"]),
    ("mitchell", ["--generator", "mitchell", "--method", "conventional", "--display", "centred"]),
    ("hex-quartic 2x2", ["--lattice", "hex", "--generator", "hex-quartic", "--display", "2x2"]),
]
HEADLINE = "siproject min-error cubic 2x2"
HEX = "siproject hex-quartic 2x2"
DECODE = "decode floor (sidecode)"
DECODE_FLOAT = "decode to float (sidecode --as-float)"
DECODE_READERS = "decode as siproject reads, a reader per core (sidecode --readers {n})"
STARTUP = "start-up floor (sidecode, 16 x 16 input)"
OIIO_BSPLINE = "oiiotool bspline"

# Targets (issue 8).
TARGET_RATIO_OIIO = 0.5
TARGET_RATIO_DECODE = 1.3
TARGET_PEAK_MB = 200
TARGET_THREAD_SPEEDUP = 1.6
TARGET_RATIO_HEX = 2.0  # the hexagonal lattice against the Cartesian cubic (issue 21)


class BenchError(Exception):
    pass


def log(message):
    print(f"{PROG}: {message}", file=sys.stderr, flush=True)


def rel(path):
    """PATH relative to the project root when inside it (for the report)."""
    p = os.path.abspath(path)
    return os.path.relpath(p, ROOT) if p.startswith(ROOT + os.sep) else p


# ---- tools ---------------------------------------------------------------------

def require_file(path, what, hint):
    if not (os.path.isfile(path) and os.access(path, os.X_OK)):
        raise BenchError(f"{what} not found or not executable: {path} ({hint})")


def require_command(name, hint):
    path = shutil.which(name)
    if path is None:
        raise BenchError(f"{name} not found on PATH ({hint})")
    return path


def check_tools(args):
    """Every tool the run needs, before anything is rendered or timed."""
    hint_build = "run make build, or pass its path"
    require_file(args.siproject, "siproject", hint_build)
    require_file(args.sidecode, "sidecode", hint_build)
    require_file(args.microbench, "microbench", hint_build)
    require_file(os.path.join(args.build, "tools", "sirays"), "sirays", hint_build)
    require_file(args.python, "the project's Python", "run scripts/setup.sh")
    if not os.path.isfile("/usr/bin/time"):
        raise BenchError("/usr/bin/time not found (Debian package time; run scripts/setup.sh)")
    require_command("oiiotool", "Debian package openimageio-tools; run scripts/setup.sh")
    require_command("povray", "Debian package povray; run scripts/setup.sh")
    probe = subprocess.run(
        [args.python, "-c", "import splineops, OpenEXR, numpy; from splineops.resize import resize_degrees"],
        capture_output=True, text=True)
    if probe.returncode != 0:
        raise BenchError(f"{args.python} cannot import splineops/OpenEXR/numpy "
                         f"(run scripts/setup.sh): {probe.stderr.strip().splitlines()[-1:]}")


def snapshot_binaries(args, folder):
    """Copies the C++ binaries into FOLDER: the whole run uses one build even if
    the tree is rebuilt meanwhile. Returns their SHA-256 (short) for the report."""
    digests = {}
    for attr in ("siproject", "sidecode", "microbench"):
        src = getattr(args, attr)
        dst = os.path.join(folder, os.path.basename(src))
        shutil.copy2(src, dst)
        with open(dst, "rb") as f:
            digests[attr] = hashlib.sha256(f.read()).hexdigest()[:12]
        setattr(args, attr, dst)
    return digests


def capture(cmd):
    try:
        return subprocess.run(cmd, capture_output=True, text=True).stdout.strip()
    except OSError:
        return ""


# ---- inputs --------------------------------------------------------------------

def ensure_render(args, scene, res, factor, samples="regular"):
    """The render of SCENE at RES^2 output pixels and FACTOR (SAMPLES: the
    pattern), made by make in OUTDIR (make render OUT=OUTDIR ...: the
    Makefile's one staleness rule; made once, remade when its scene,
    povray.ini, size, factor or options change). Returns (path, statistics
    that scripts/render.sh wrote beside it)."""
    pov = os.path.join(ROOT, "scenes", f"{scene}.pov")
    if not os.path.isfile(pov):
        scenes = sorted(f[:-4] for f in os.listdir(os.path.join(ROOT, "scenes")) if f.endswith(".pov"))
        raise BenchError(f"no scene {rel(pov)}; scenes: {' '.join(scenes)}")
    t0 = time.perf_counter()
    try:
        path, stats, made = make_render(args.outdir, scene, res, factor, samples=samples, seed=args.scatter_seed,
                                        build=args.build)
    except RenderError as e:
        raise BenchError(str(e))
    if made:
        log(f"rendered {rel(path)} in {time.perf_counter() - t0:.0f} s (once; reused by later runs)")
    return path, stats


def describe_exr(path):
    """Size, channels, pixel type and compression of an image (oiiotool --info -v),
    and its file size."""
    text = capture(["oiiotool", "--info", "-v", path])
    info = {"bytes": os.path.getsize(path)}
    m = re.search(r": +(\d+) x +(\d+), (\d+) channel, (\w+) ", text)
    if m:
        info.update(width=int(m.group(1)), height=int(m.group(2)), type=m.group(4))
        ch = re.search(r"channel list: (.*)", text)
        info["channels"] = ch.group(1).replace(", ", "") if ch else "?" * int(m.group(3))
        comp = re.search(r'compression: "([^"]*)"', text)
        info["compression"] = comp.group(1) if comp else "unknown"
    return info


def exr_text(info):
    if "width" not in info:
        return f"{info['bytes'] / 1e6:.1f} MB"
    raw = info["width"] * info["height"] * len(info["channels"]) * (2 if info["type"] == "half" else 4)
    return (f"{info['width']} x {info['height']} {info['channels']} {info['type']}, "
            f"{info['compression']} compression, {info['bytes'] / 1e6:.1f} MB on disk "
            f"({raw / info['bytes']:.1f}:1 against {raw / 1e6:.0f} MB raw)")


def warm_cache(path):
    """Reads PATH once, so that the first competitor does not pay for the disk."""
    with open(path, "rb") as f:
        while f.read(1 << 24):
            pass


# ---- timing --------------------------------------------------------------------

STAGE_RE = re.compile(r"([a-z+]+) ([0-9.]+) s")


def timed_run(cmd, workdir, name):
    """Runs CMD under /usr/bin/time -v. Returns (wall seconds, peak RSS in MiB,
    CPU seconds (user + system), stderr text). Raises BenchError naming the competitor if it fails."""
    timefile = os.path.join(workdir, "time.txt")
    t0 = time.perf_counter()
    r = subprocess.run(["/usr/bin/time", "-v", "-o", timefile] + cmd,
                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise BenchError(f"{name} failed with status {r.returncode}: {shlex.join(cmd)}\n{r.stderr.strip()}")
    with open(timefile) as f:
        text = f.read()
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
    if not m:
        raise BenchError(f"no 'Maximum resident set size' from /usr/bin/time -v for {name}")
    cpu = sum(float(x) for x in re.findall(r"(?:User|System) time \(seconds\): ([0-9.]+)", text))
    return wall, int(m.group(1)) / 1024, cpu, r.stderr


def stage_times(stderr):
    """siproject -v stage times: {'read+acquire': s, 'prefilter': s, ...}."""
    for line in stderr.splitlines():
        if "total" in line and "read" in line:
            return {k: float(v) for k, v in STAGE_RE.findall(line)}
    return {}


def load_average():
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "?"


LOADS = []  # 1-minute load average before each timed run
BUSY = []   # cores busy with other work just before each timed run


def cpu_times():
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    idle = v[3] + v[4]  # idle + iowait
    return sum(v[:8]), idle  # user..steal (guest time is inside user)


WAIT_IDLE = 0.0  # --wait-idle: seconds to wait for an idle machine before each timed run
IDLE_BELOW = 0.25  # cores busy with other work under which the machine counts as idle


def wait_for_idle():
    """Cores busy with other work just before a timed run. With --wait-idle S,
    first waits up to S seconds for that to fall below IDLE_BELOW."""
    deadline = time.monotonic() + WAIT_IDLE
    busy = busy_cores()
    while busy >= IDLE_BELOW and time.monotonic() < deadline:
        busy = busy_cores(1.0)
    return busy


def busy_cores(interval=0.3):
    """Cores kept busy by other processes over INTERVAL seconds (the bench runs
    nothing meanwhile)."""
    t0, i0 = cpu_times()
    time.sleep(interval)
    t1, i1 = cpu_times()
    return (os.cpu_count() or 1) * (1 - (i1 - i0) / max(1, t1 - t0))


def round_robin(competitors, runs, workdir):
    """Runs every competitor once per round, RUNS rounds. Fills each
    competitor's 'walls', 'rss', 'stages'."""
    for c in competitors:
        c.update(walls=[], rss=[], cpu=[], stages=[])
    total = runs * len(competitors)
    done = 0
    for rnd in range(runs):
        for c in competitors:
            done += 1
            LOADS.append(float(load_average().split()[0]))
            BUSY.append(wait_for_idle())
            wall, rss, cpu, err = timed_run(c["cmd"], workdir, c["name"])
            c["walls"].append(wall)
            c["cpu"].append(cpu)
            c["rss"].append(rss)
            st = stage_times(err)
            if st:
                c["stages"].append(st)
            log(f"[{done}/{total}] round {rnd + 1}: {c['name']:<40} {wall:7.2f} s  "
                f"cpu {cpu:6.2f} s {rss:6.0f} MB  (other work: {BUSY[-1]:.1f} cores busy before)")


def median_stages(c):
    if not c.get("stages"):
        return {}
    keys = c["stages"][0].keys()
    return {k: statistics.median(s[k] for s in c["stages"]) for k in keys}


# ---- thread invariance and the microbenchmark ------------------------------------

def identical_pixels(a, b):
    """True when the two images have the same size, channels and bit-identical
    pixels (read by the Python module: half samples widen to float exactly)."""
    try:
        import siproject
        x, y = siproject.read_image(a), siproject.read_image(b)
    except (ImportError, OSError, ValueError) as e:
        raise BenchError(f"comparing {a} and {b} failed: {e}")
    return x.shape == y.shape and x.tobytes() == y.tobytes()


def microbench_acquisition(microbench, rounds):
    """BM_Acquisition/DEGREE/THREADS real time in ms: the median over ROUNDS
    invocations of microbench, each running 1 and 2 threads in turn (so that a
    change in load falls on both). Returns ({(degree, threads): [ms, ...]}, cmd)."""
    cmd = [microbench, "--benchmark_filter=^BM_Acquisition/", "--benchmark_format=json"]
    times = {}
    for rnd in range(rounds):
        BUSY.append(wait_for_idle())
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            raise BenchError(f"microbench failed with status {r.returncode}: {r.stderr.strip()}")
        for b in json.loads(r.stdout)["benchmarks"]:
            m = re.match(r"BM_Acquisition/(\d+)/(\d+)", b["name"])
            if m:
                assert b["time_unit"] == "ms", b["time_unit"]
                times.setdefault((int(m.group(1)), int(m.group(2))), []).append(b["real_time"])
        log(f"microbench round {rnd + 1}/{rounds}: " + ", ".join(
            f"degree {d} x{t} {v[-1]:.0f} ms" for (d, t), v in sorted(times.items()))
            + f"  (other work: {BUSY[-1]:.1f} cores busy before)")
    return times, cmd


# ---- report --------------------------------------------------------------------

def fmt_ratio(x):
    return f"{x:.2f}" if x is not None else ""


def build_rows(competitors, big):
    by_name = {c["name"]: c for c in competitors}
    floor = statistics.median(by_name[DECODE]["walls"])
    bspline = statistics.median(by_name[OIIO_BSPLINE]["walls"])
    rows = []
    for c in competitors + big:
        wall = statistics.median(c["walls"])
        same_input = c.get("group") not in ("big", "scattered")
        rows.append({
            "group": c["group"],
            "kind": c.get("kind"),
            "competitor": c["name"],
            "input": c["input"],
            "runs": len(c["walls"]),
            "wall_median_s": wall,
            "wall_min_s": min(c["walls"]),
            "wall_max_s": max(c["walls"]),
            "ratio_decode": wall / floor if same_input else (wall / c["floor"] if c.get("floor") else None),
            "ratio_oiio_bspline": wall / bspline if same_input else None,
            # per round against the floor's run in the same round (which
            # shares that round's load), for reading the ratio through noise
            "paired_decode": ([w / f for w, f in zip(c["walls"], by_name[DECODE]["walls"])]
                              if same_input else []),
            "peak_rss_mb": max(c["rss"]),
            "cpu_median_s": statistics.median(c["cpu"]),
            "stages": median_stages(c),
            "command": c["display"],
        })
    return rows


def csv_text(rows, meta):
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["group", "competitor", "input", "output", "runs", "wall_median_s", "wall_min_s",
                "wall_max_s", "ratio_decode_floor", "ratio_oiiotool_bspline", "peak_rss_mb", "cpu_median_s",
                "stages_median_s", "command"])
    for r in rows:
        stages = ";".join(f"{k}={v:.3f}" for k, v in r["stages"].items())
        w.writerow([r["group"], r["competitor"], r["input"], meta["out_size"], r["runs"],
                    f"{r['wall_median_s']:.3f}", f"{r['wall_min_s']:.3f}", f"{r['wall_max_s']:.3f}",
                    fmt_ratio(r["ratio_decode"]), fmt_ratio(r["ratio_oiio_bspline"]),
                    f"{r['peak_rss_mb']:.0f}", f"{r['cpu_median_s']:.3f}", stages, r["command"]])
    return buf.getvalue()


def md_text(rows, meta, threads, micro):
    L = []
    L.append("# Benchmark: siproject against oiiotool, splineops and the decode floor")
    L.append("")
    L.append(f"Made by `{meta['command']}` on {meta['date']}{' (QUICK mode: small input, one run)' if meta['quick'] else ''}.")
    L.append("")
    L.append(f"- machine: {meta['cpu']}, nproc {meta['nproc']}, {meta['mem_gb']:.1f} GB RAM, {meta['os']}")
    L.append(f"- load average (1, 5, 15 min; `uptime`): {meta['load_start']} at the start, "
             f"{meta['load_end']} at the end; 1-minute load before the timed runs "
             f"{min(LOADS):.2f} to {max(LOADS):.2f} (median {statistics.median(LOADS):.2f}; it counts the "
             f"bench's own runs too). Cores busy with other work, sampled for 0.3 s before each timed "
             f"run (/proc/stat{f', after waiting up to {WAIT_IDLE:g} s for them to be idle' if WAIT_IDLE else ''}): "
             f"median {statistics.median(BUSY):.2f}, max {max(BUSY):.2f} of {meta['nproc']}. Other work on the machine inflates the times; "
             f"the rounds alternate competitors, so it falls on all of them alike.")
    if statistics.median(BUSY) >= 0.25:
        L.append(f"- **warning**: the machine was busy (other work kept {statistics.median(BUSY):.1f} "
                 f"of {meta['nproc']} cores busy, median before the runs): wall times are inflated and noisy, and thread scaling "
                 f"cannot show (a second thread only helps when a core is free). Re-run on an "
                 f"idle machine for the thread targets.")
    L.append(f"- input: `{meta['input']}` ({meta['input_info']}), scene {meta['scene']}, "
             f"rendered by `make render` (POV-Ray, antialiasing off)")
    L.append(f"- output: {meta['out_size']}; every competitor is a whole process "
             f"(read, resize, write a 1-part zip EXR of the input's sample type: half, as "
             f"oiiotool keeps it), timed by wall clock; the decode floor reads the samples as "
             f"stored with OpenImageIO, in strips through OpenEXR's pool (the targets' floor), OpenImageIO's serial "
             f"conversion to float is the row below it, and below that the same file decoded "
             f"as siproject reads it, band by band by a reader per core with OpenEXR's pool "
             f"off, the samples not used (sidecode --readers; for information); "
             f"{meta['runs']} round(s), each running every competitor once in turn; "
             f"wall = median over the rounds (min-max beside it), CPU = median user+system "
             f"time (less sensitive to other load than wall); peak memory = largest "
             f"'Maximum resident set size' of /usr/bin/time -v over the rounds, in MB (2^20 bytes)")
    L.append(f"- versions: {meta['oiio']}; splineops {meta['splineops']} "
             f"(least-squares resize, equal analysis and synthesis degree, its native "
             f"extension on all cores); siproject from git {meta['git']} "
             f"(binaries sha256 {meta['digests']})")
    L.append("")
    L.append("| competitor | wall (s), median | min-max (s) | / decode floor | / oiiotool bspline | peak memory (MB) | CPU (s), user+sys |")
    L.append("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        if r["group"] in ("threads", "big", "scattered"):
            continue
        name = f"**{r['competitor']}**" if r["competitor"] == HEADLINE else r["competitor"]
        L.append(f"| {name} | {r['wall_median_s']:.2f} | {r['wall_min_s']:.2f}-{r['wall_max_s']:.2f} | "
                 f"{fmt_ratio(r['ratio_decode'])} | {fmt_ratio(r['ratio_oiio_bspline'])} | {r['peak_rss_mb']:.0f} | "
                 f"{r['cpu_median_s']:.2f} |")
    big = [r for r in rows if r["group"] == "big"]
    if big:
        L.append("")
        L.append(f"At scale (**one run each**, not a median): input `{meta['big_input']}` "
                 f"({meta['big_info']}), output {meta['out_size']}.")
        L.append("")
        L.append("| competitor | wall (s), 1 run | / decode floor of this input | peak memory (MB) | CPU (s), user+sys |")
        L.append("| --- | ---: | ---: | ---: | ---: |")
        for r in big:
            L.append(f"| {r['competitor']} | {r['wall_median_s']:.2f} | {fmt_ratio(r['ratio_decode'])} | "
                     f"{r['peak_rss_mb']:.0f} | {r['cpu_median_s']:.2f} |")
    L.extend(scatter_text(rows, meta))
    L.append("")
    L.append("## Threads")
    L.append("")
    L.append(f"siproject min-error cubic 2x2 on the same input at `--threads 1` and `--threads 2` "
             f"(in the same rounds as the table): outputs **{'bit-identical' if threads['identical'] else 'DIFFERENT'}** "
             f"(every channel's pixel bytes compared).")
    L.append("")
    t1, t2 = threads["t1"], threads["t2"]
    L.append("| stage | 1 thread (s) | 2 threads (s) | speedup |")
    L.append("| --- | ---: | ---: | ---: |")
    for k in t1["stages"]:
        if k in t2["stages"] and t2["stages"][k] > 0:
            L.append(f"| {k} (siproject -v) | {t1['stages'][k]:.3f} | {t2['stages'][k]:.3f} | "
                     f"{t1['stages'][k] / t2['stages'][k]:.2f} |")
    L.append(f"| whole process | {t1['wall_median_s']:.2f} | {t2['wall_median_s']:.2f} | "
             f"{t1['wall_median_s'] / t2['wall_median_s']:.2f} |")
    L.append("")
    L.append(f"Compute stage alone: `{micro['command']}` (4000 x 4000 RGB in memory onto "
             f"1000 x 1000 coefficients, real time in ms; {micro['repetitions']} invocation(s), "
             f"each running 1 then 2 threads; median, range in brackets):")
    L.append("")
    L.append("| BM_Acquisition | 1 thread (ms) | 2 threads (ms) | speedup |")
    L.append("| --- | ---: | ---: | ---: |")
    for d in sorted({k[0] for k in micro["times"]}):
        a, b = micro["times"].get((d, 1)), micro["times"].get((d, 2))
        if a and b:
            sa, sb = micro["samples"][(d, 1)], micro["samples"][(d, 2)]
            L.append(f"| degree {d} | {a:.1f} [{min(sa):.0f}-{max(sa):.0f}] | "
                     f"{b:.1f} [{min(sb):.0f}-{max(sb):.0f}] | {a / b:.2f} |")
    L.append("")
    L.append("## Targets")
    L.append("")
    for ok, text in meta["checks"]:
        L.append(f"- {'met' if ok else '**not met**'}: {text}")
    L.append("")
    L.append("## Commands")
    L.append("")
    L.append("OUT/ is a temporary folder, removed at the end.")
    L.append("")
    for r in rows:
        L.append(f"- {r['competitor']}: `{r['command']}`")
    L.append("")
    return "\n".join(L)


def kind_label(args, kind):
    n = int(args.scatter_res * args.scatter_factor + 0.5)
    return (f"{n}^2 regular render" if kind == "regular"
            else f"{n}^2 {args.scatter_pattern} render (seed {args.scatter_seed})")


def scatter_rays(args):
    return int(args.scatter_res * args.scatter_factor + 0.5) ** 2


def scatter_text(rows, meta):
    """The scattered render's rows: siproject on it against the same size's
    regular render, per sample; its mesh bands' costs against POV-Ray's
    parse of them."""
    sc = meta.get("scatter")
    if not sc:
        return []
    by = {r.get("kind"): r for r in rows if r["group"] == "scattered"}
    reg, sca = by["regular"], by["scattered"]
    rays = sc["rays"]
    L = ["", f"Scattered rays: `{sc['scattered']}` ({sc['pattern']} rays, seed {sc['seed']}, {rays / 1e6:.2f} M rays "
         f"over {sc['res']} x {sc['res']} output pixels, factor {sc['factor']:g}: `make render SCENE={meta['scene']} "
         f"RES={sc['res']} FACTOR={sc['factor']:g} SAMPLES={sc['pattern']} SEED={sc['seed']}`) against the regular "
         f"render of the same size `{sc['regular']}`, siproject min-error cubic 2x2 onto {sc['res']} x {sc['res']}, "
         f"{reg['runs']} round(s) each, alternated:", "",
         "| input | wall (s), median | min-max (s) | per sample (ns) | peak memory (MB) | CPU (s), user+sys |",
         "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for r in (reg, sca):
        L.append(f"| {r['competitor'].split(', ', 1)[1]} | {r['wall_median_s']:.2f} | "
                 f"{r['wall_min_s']:.2f}-{r['wall_max_s']:.2f} | {1e9 * r['wall_median_s'] / rays:.0f} | "
                 f"{r['peak_rss_mb']:.0f} | {r['cpu_median_s']:.2f} |")
    L.append(f"| scattered / regular | {sca['wall_median_s'] / reg['wall_median_s']:.2f} | | | "
             f"{sca['peak_rss_mb'] / reg['peak_rss_mb']:.2f} | {sca['cpu_median_s'] / reg['cpu_median_s']:.2f} |")
    L.append("")
    L.append(f"Its render, once, when make made it (`make render ... SAMPLES={sc['pattern']}`: each mesh band "
             f"written by `sirays mesh` and rendered by one POV-Ray process, one band after another; "
             f"times from the render's statistics, `{sc['scattered'][:-4]}.stats` and its bands'; POV-Ray's parse "
             f"and trace times as it prints them with +GS; POV-Ray's wall includes its start-up, parse and trace):")
    L.append("")
    L.append("| band | rays | mesh (MB) | sirays mesh (s) | POV-Ray parse (s) | mesh / parse | POV-Ray trace (s) | POV-Ray wall (s) |")
    L.append("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    bands = sc["bands"]
    for i, b in enumerate(bands):
        L.append(f"| {i} | {b['rays']} | {b['mesh_bytes'] / 1e6:.0f} | {b['mesh_s']:.2f} | {b['parse_s']:.2f} | "
                 f"{b['mesh_s'] / b['parse_s']:.2f} | {b['trace_s']:.2f} | {b['wall_s']:.2f} |")
    t = sc["scattered_stats"]
    L.append(f"| all {len(bands)} | {t['rays']} | {t['mesh_bytes'] / 1e6:.0f} | {t['mesh_s']:.2f} | "
             f"{t['parse_s']:.2f} | {t['mesh_s'] / t['parse_s']:.2f} | {t['trace_s']:.2f} | {t['wall_s']:.2f} |")
    g = sc["regular_stats"]
    L.append(f"| regular render | {rays} | | | {g['parse_s']:.2f} | | {g['trace_s']:.2f} | {g['wall_s']:.2f} |")
    L.append("")
    L.append(f"Per million rays: sirays mesh {1e6 * t['mesh_s'] / t['rays']:.2f} s, POV-Ray's parse "
             f"{1e6 * t['parse_s'] / t['rays']:.2f} s, mesh text {t['mesh_bytes'] / t['rays']:.0f} bytes per ray.")
    return L


def targets(rows, threads, micro):
    by = {r["competitor"]: r for r in rows if r["group"] not in ("big", "scattered")}
    head = by[HEADLINE]
    checks = [
        (head["ratio_oiio_bspline"] <= TARGET_RATIO_OIIO,
         f"{HEADLINE} <= {TARGET_RATIO_OIIO}x oiiotool bspline time: {head['ratio_oiio_bspline']:.2f}x"),
        (head["ratio_decode"] <= TARGET_RATIO_DECODE,
         f"{HEADLINE} <= {TARGET_RATIO_DECODE}x the decode floor: {head['ratio_decode']:.2f}x "
         f"(median over the rounds of each round's ratio: {statistics.median(head['paired_decode']):.2f}x, "
         f"{min(head['paired_decode']):.2f}-{max(head['paired_decode']):.2f}; judged on the ratio of the medians)"),
        (head["peak_rss_mb"] <= TARGET_PEAK_MB,
         f"{HEADLINE} peak memory <= {TARGET_PEAK_MB} MB at {head['input']}: {head['peak_rss_mb']:.0f} MB"),
    ]
    if HEX in by:
        hexr = by[HEX]
        ratio = hexr["wall_median_s"] / head["wall_median_s"]
        checks.append((ratio <= TARGET_RATIO_HEX,
                       f"{HEX} <= {TARGET_RATIO_HEX}x {HEADLINE} time: {ratio:.2f}x "
                       f"({hexr['wall_median_s']:.2f} s against {head['wall_median_s']:.2f} s, medians)"))
        checks.append((hexr["peak_rss_mb"] <= TARGET_PEAK_MB,
                       f"{HEX} peak memory <= {TARGET_PEAK_MB} MB at {hexr['input']}: "
                       f"{hexr['peak_rss_mb']:.0f} MB"))
    for r in rows:
        if r["group"] == "big" and r["competitor"].startswith("siproject"):
            checks.append((r["peak_rss_mb"] <= TARGET_PEAK_MB,
                           f"{r['competitor']} peak memory <= {TARGET_PEAK_MB} MB at {r['input']}: "
                           f"{r['peak_rss_mb']:.0f} MB (1 run)"))
    for d in sorted({k[0] for k in micro["times"]}):
        a, b = micro["times"].get((d, 1)), micro["times"].get((d, 2))
        if a and b:
            checks.append((a / b >= TARGET_THREAD_SPEEDUP,
                           f"2 threads >= {TARGET_THREAD_SPEEDUP}x one on the compute stage "
                           f"(BM_Acquisition degree {d}): {a / b:.2f}x"))
    checks.append((threads["identical"], "--threads 1 and --threads 2 outputs bit-identical"))
    return checks


# ---- main ----------------------------------------------------------------------

def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.HelpFormatter)
    ap.add_argument("--quick", action="store_true", default=os.environ.get("QUICK") == "1",
                    help="small input, one run each (also QUICK=1 in the environment)")
    ap.add_argument("--scene", default="objects", help="scene of the input render: scenes/SCENE.pov (default objects)")
    ap.add_argument("--render-size", type=int, default=None, help="input render size N (N x N); default 8000, quick 1000")
    ap.add_argument("--out-size", type=int, default=None, help="output size N (N x N); default 1000, quick 250")
    ap.add_argument("--runs", type=int, default=None, help="rounds (median over them); default 3, quick 1")
    ap.add_argument("--big-scene", default="checker", help="scene of the input at scale, for peak memory (default checker)")
    ap.add_argument("--big-size", type=int, default=None, help="its render size; default 16000, quick 2000")
    ap.add_argument("--no-big", action="store_true", help="skip the input at scale")
    ap.add_argument("--scatter-res", type=int, default=None,
                    help="the scattered render's output size N (N x N); default 500, quick 125")
    ap.add_argument("--scatter-factor", type=float, default=4,
                    help="its factor: (N FACTOR)^2 rays (default 4: 2000^2, 4 M rays)")
    ap.add_argument("--scatter-pattern", default="jitter", choices=("jitter", "sobol"),
                    help="its pattern (default jitter)")
    ap.add_argument("--scatter-seed", type=int, default=0, help="its seed (default 0)")
    ap.add_argument("--no-scatter", action="store_true", help="skip the scattered render")
    ap.add_argument("--wait-idle", type=float, default=0, metavar="S",
                    help="before each timed run, wait up to S seconds for other work to leave "
                         f"the cores idle (under {IDLE_BELOW} busy); for shared machines")
    ap.add_argument("--outdir", default=os.path.join(ROOT, "out", "bench"), help="renders and results (default out/bench)")
    ap.add_argument("--build", default=os.path.join(ROOT, "build"), help="build folder of the C++ tools (default build)")
    ap.add_argument("--siproject", default=None, help="siproject binary (default BUILD/tools/siproject)")
    ap.add_argument("--sidecode", default=None, help="sidecode binary (default BUILD/tools/sidecode)")
    ap.add_argument("--microbench", default=None, help="microbench binary (default BUILD/tests/microbench)")
    ap.add_argument("--python", default=os.path.join(ROOT, ".venv", "bin", "python"),
                    help="Python with splineops and OpenEXR (default: the project's .venv)")
    args = ap.parse_args()
    q = args.quick
    args.render_size = args.render_size or (1000 if q else 8000)
    args.out_size = args.out_size or (250 if q else 1000)
    args.runs = args.runs or (1 if q else 3)
    args.big_size = args.big_size or (2000 if q else 16000)
    args.scatter_res = args.scatter_res or (125 if q else 500)
    if not args.scatter_factor > 0 or args.scatter_seed < 0:
        ap.error("--scatter-factor must be positive and --scatter-seed at least 0")
    for name in ("render_size", "out_size", "runs", "big_size", "scatter_res"):
        if getattr(args, name) <= 0:
            ap.error(f"--{name.replace('_', '-')} must be positive")
    if args.out_size > args.render_size:
        ap.error("--out-size must not exceed --render-size (this is a downsampling benchmark)")
    args.siproject = os.path.abspath(args.siproject or os.path.join(args.build, "tools", "siproject"))
    args.sidecode = os.path.abspath(args.sidecode or os.path.join(args.build, "tools", "sidecode"))
    args.microbench = os.path.abspath(args.microbench or os.path.join(args.build, "tests", "microbench"))
    args.outdir = os.path.abspath(args.outdir)
    args.build = os.path.abspath(args.build)
    return args


def competitors_for(args, inp, work):
    size = f"{args.out_size}x{args.out_size}"
    script = os.path.join(HERE, "splineops_resize.py")
    out = lambda tag: os.path.join(work, tag + ".exr")
    # (group, name, command); the displayed command uses the project's paths.
    comps = [("floor", STARTUP, [args.sidecode, os.path.join(work, "tiny.exr")]),
             ("floor", DECODE, [args.sidecode, inp]),
             ("floor", DECODE_FLOAT, [args.sidecode, inp, "--as-float"]),
             ("floor", DECODE_READERS.format(n=os.cpu_count() or 1),
              [args.sidecode, inp, "--readers", str(os.cpu_count() or 1)])]
    for f in OIIO_FILTERS:
        comps.append(("oiiotool", f"oiiotool {f}",
                      ["oiiotool", inp, f"--resize:filter={f}", size, "-o", out("oiio-" + f)]))
    for d in (1, 3):
        comps.append(("splineops", f"splineops least-squares degree {d}",
                      [args.python, script, inp, "-o", out(f"splineops-{d}"), "--size", size, "--degree", str(d)]))
    for name, opts in SIPROJECT_METHODS:
        tag = "si-" + name.replace(" ", "-")
        comps.append(("siproject", "siproject " + name,
                      [args.siproject, inp, "-o", out(tag), "--size", size] + opts + ["-v"]))
    me_cubic = SIPROJECT_METHODS[0][1]
    for t in (1, 2):
        comps.append(("threads", f"{HEADLINE} --threads {t}",
                      [args.siproject, inp, "-o", out(f"threads-{t}"), "--size", size] + me_cubic
                      + ["--threads", str(t), "-v"]))
    return [{"group": group, "name": name, "cmd": cmd, "input": f"{args.render_size}^2"}
            for group, name, cmd in comps]


def main():
    global WAIT_IDLE
    args = parse_args()
    WAIT_IDLE = max(0.0, args.wait_idle)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    check_tools(args)
    os.makedirs(args.outdir, exist_ok=True)
    load_start = load_average()
    work = tempfile.mkdtemp(prefix=".bench-work.", dir=args.outdir)
    try:
        tools_dir = os.path.join(work, "bin")
        os.mkdir(tools_dir)
        original = {k: getattr(args, k) for k in ("siproject", "sidecode", "microbench")}
        digests = snapshot_binaries(args, tools_dir)

        inp, _ = ensure_render(args, args.scene, args.render_size, 1)
        big_inp = None if args.no_big else ensure_render(args, args.big_scene, args.big_size, 1)[0]
        scatter = None
        if not args.no_scatter:
            res, f = args.scatter_res, args.scatter_factor
            reg, reg_stats = ensure_render(args, args.scene, res, f)
            sca, sca_stats = ensure_render(args, args.scene, res, f, samples=args.scatter_pattern)
            bands = [read_stats(f"{sca[:-4]}-mesh{i}of{sca_stats['bands']}.stats")
                     for i in range(int(sca_stats["bands"]))]
            scatter = {"regular": reg, "scattered": sca, "regular_stats": reg_stats,
                       "scattered_stats": sca_stats, "bands": bands}
        info = describe_exr(inp)
        log(f"input {rel(inp)}: {exr_text(info)}")

        def shown(cmd):
            """CMD as the report shows it: the project's binaries, not their
            snapshots; competitors' outputs in the work folder as OUT/."""
            snap = {getattr(args, k): v for k, v in original.items()}
            cmd = [snap.get(x, x) for x in cmd]
            cmd = [x.replace(work + os.sep, "OUT/") for x in cmd]
            return shlex.join(rel(x) if os.path.isabs(x) else x for x in cmd)

        r = subprocess.run(["oiiotool", "--pattern", "constant:color=0.5,0.5,0.5", "16x16", "3",
                            "-d", "half", "-o", os.path.join(work, "tiny.exr")], capture_output=True, text=True)
        if r.returncode != 0:
            raise BenchError(f"oiiotool could not write a 16 x 16 test image: {r.stderr.strip()}")
        comps = competitors_for(args, inp, work)
        for c in comps:
            c["display"] = shown(c["cmd"])
        warm_cache(inp)
        log(f"{args.runs} round(s) of {len(comps)} competitors, output {args.out_size} x {args.out_size}")
        round_robin(comps, args.runs, work)

        t1 = next(c for c in comps if c["name"].endswith("--threads 1"))
        t2 = next(c for c in comps if c["name"].endswith("--threads 2"))
        identical = identical_pixels(os.path.join(work, "threads-1.exr"),
                                     os.path.join(work, "threads-2.exr"))
        log(f"--threads 1 and --threads 2 outputs {'bit-identical' if identical else 'DIFFER'}")

        big = []
        big_info = None
        if big_inp:
            big_info = describe_exr(big_inp)
            warm_cache(big_inp)
            size = f"{args.out_size}x{args.out_size}"
            tag = f"{args.big_size}^2 {args.big_scene}"
            floor = {"group": "big", "name": f"decode floor (sidecode), {tag}", "cmd": [args.sidecode, big_inp]}
            si = {"group": "big", "name": f"{HEADLINE}, {tag}",
                  "cmd": [args.siproject, big_inp, "-o", os.path.join(work, "big.exr"), "--size", size]
                  + SIPROJECT_METHODS[0][1] + ["-v"]}
            big = [floor, si]
            for c in big:
                c["input"] = f"{args.big_size}^2"
                c["display"] = shown(c["cmd"])
            log(f"input at scale {rel(big_inp)}: {exr_text(big_info)}")
            round_robin(big, 1, work)
            si["floor"] = floor["walls"][0]
            floor["floor"] = floor["walls"][0]

        scat = []
        if scatter:
            size = f"{args.scatter_res}x{args.scatter_res}"
            for kind in ("regular", "scattered"):
                src = scatter[kind]
                warm_cache(src)
                scat.append({"group": "scattered", "kind": kind,
                             "name": f"{HEADLINE}, {kind_label(args, kind)}",
                             "cmd": [args.siproject, src, "-o", os.path.join(work, f"scatter-{kind}.exr"),
                                     "--size", size] + SIPROJECT_METHODS[0][1] + ["-v"]})
            rays = scatter_rays(args)
            for c in scat:
                c["input"] = f"{rays} rays"
                c["display"] = shown(c["cmd"])
            log(f"scattered rays: {rel(scatter['scattered'])} against {rel(scatter['regular'])}, "
                f"{args.runs} round(s)")
            round_robin(scat, args.runs, work)

        reps = 1 if args.quick else max(5, args.runs)  # as many rounds as the table, at least 5
        log(f"microbench BM_Acquisition at 1 and 2 threads ({reps} round(s))")
        samples, mcmd = microbench_acquisition(args.microbench, reps)
        times = {k: statistics.median(v) for k, v in samples.items()}
        micro = {"times": times, "samples": samples, "repetitions": reps,
                 "command": shlex.join([rel(original["microbench"])] + mcmd[1:])}
        load_end = load_average()

        rows = build_rows(comps, big + scat)
        by = {r["competitor"]: r for r in rows}
        threads = {"identical": identical,
                   "t1": by[t1["name"]], "t2": by[t2["name"]]}
        from_env = args.quick and "--quick" not in sys.argv[1:]
        cmdline = " ".join([("QUICK=1 " if from_env else "")
                            + rel(args.python), rel(__file__)] + sys.argv[1:])
        meta = {
            "command": cmdline.strip(),
            "date": time.strftime("%Y-%m-%d %H:%M %Z"),
            "quick": args.quick,
            "cpu": cpu_model(),
            "nproc": os.cpu_count(),
            "mem_gb": os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30,
            "os": platform.platform(terse=True),
            "load_start": load_start,
            "load_end": load_end,
            "input": rel(inp),
            "input_info": exr_text(info),
            "scene": args.scene,
            "big_input": rel(big_inp) if big_inp else "",
            "big_info": exr_text(big_info) if big_info else "",
            "out_size": f"{args.out_size} x {args.out_size}",
            "runs": args.runs,
            "oiio": capture(["oiiotool", "--version"]) and "oiiotool " + capture(["oiiotool", "--version"]),
            "splineops": capture([args.python, "-c", "import importlib.metadata as m; print(m.version('splineops'))"]),
            "git": (capture(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]) or "?")
                   + (" with uncommitted changes" if capture(["git", "-C", ROOT, "status", "--porcelain",
                                                              "--untracked-files=no"]) else ""),
            "digests": ", ".join(f"{k} {v}" for k, v in digests.items()),
            "scatter": scatter and {**scatter, "regular": rel(scatter["regular"]),
                                    "scattered": rel(scatter["scattered"]),
                                    "pattern": args.scatter_pattern, "seed": args.scatter_seed,
                                    "res": args.scatter_res, "factor": args.scatter_factor,
                                    "rays": scatter_rays(args)},
        }
        meta["checks"] = targets(rows, threads, micro)
        md = md_text(rows, meta, threads, micro)
        stem = os.path.join(args.outdir, "bench-quick" if args.quick else "bench")
        write_atomic(stem + ".csv", csv_text(rows, meta))
        write_atomic(stem + ".md", md)
        print(md)
        log(f"wrote {rel(stem)}.md and {os.path.basename(stem)}.csv")
    finally:
        shutil.rmtree(work, ignore_errors=True)


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


if __name__ == "__main__":
    try:
        main()
    except BenchError as e:
        log(f"error: {e}")
        sys.exit(1)
    except KeyboardInterrupt:
        log("interrupted")
        sys.exit(130)
