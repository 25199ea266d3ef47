"""The module against careless and hostile use: wrong types, NaN where
numbers go, coordinates and sizes past the engine's indices, forks, Ctrl-C
and signals during a write. Each class fails cleanly: one line naming the
keyword or argument, no crash, no hang, nothing left behind."""

import ctypes
import glob
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings

import numpy as np
import pytest

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")
SIMETRICS = os.environ.get("SIMETRICS", "simetrics")


def samples(w=64, h=48, c=3, seed=5):
    return np.random.default_rng(seed).random((h, w, c), dtype=np.float32)


def run_python(code, *args, timeout=120):
    """Runs code in a fresh interpreter (with this one's path), returns the
    CompletedProcess; a hang is a failure, not a stuck suite."""
    try:
        return subprocess.run([sys.executable, "-c", textwrap.dedent(code), *map(str, args)],
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as e:
        pytest.fail(f"did not end within {timeout} s: {e.stdout} {e.stderr}")


# ---- crashes: coordinates ---------------------------------------------------

@pytest.mark.parametrize("lattice", ["cartesian", "hex"])
@pytest.mark.parametrize("x,y,named", [
    (5.0, np.nan, "y"), (np.nan, 5.0, "x"), (np.inf, 5.0, "x"), (5.0, -np.inf, "y"),
    (1e300, 5.0, "x"), (5.0, -3e9, "y"),
])
def test_evaluate_refuses_nan_and_coordinates_past_the_indices(lattice, x, y, named):
    k = siproject.coefficients(samples(), factor=4, lattice=lattice)
    with pytest.raises(ValueError, match=rf"^evaluate\(\): {named} .*: expected a finite coordinate"):
        k.evaluate([1.5, x], [2.5, y])
    # far outside the frame but within the indices: the boundary rule's value
    mirrored = k.evaluate([1e6 + 0.5], [2.5])
    assert np.all(np.isfinite(mirrored))


# ---- hangs: fork --------------------------------------------------------------

FORK_CHILD = """
    import os, sys, multiprocessing as mp, numpy as np, siproject
    img = np.random.default_rng(1).random((240, 200, 3), dtype=np.float32)
    path = sys.argv[1]
    siproject.write_image(path, img)
    ref = siproject.project(path, factor=4, threads=3)  # the pool's workers started

    def work(threads):
        return bool(np.array_equal(siproject.project(path, factor=4, threads=threads), ref))

    if sys.argv[2] == "fork":
        pid = os.fork()
        if pid == 0:  # exits through the interpreter's and the libraries' exit handlers
            sys.exit(0 if work(1) and work(3) else 5)
        deadline = 60
        while deadline > 0:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                print("child", os.waitstatus_to_exitcode(status))
                break
            import time; time.sleep(0.1); deadline -= 0.1
        else:
            os.kill(pid, 9)
            print("child hung")
    else:
        with mp.get_context("fork").Pool(2) as pool:
            print("pool", pool.map(work, [1, 3, 2, 1]))
"""


def test_a_forked_child_projects_and_exits(tmp_path):
    r = run_python(FORK_CHILD, tmp_path / "in.exr", "fork")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "child 0"


def test_multiprocessing_with_fork_projects_and_ends(tmp_path):
    r = run_python(FORK_CHILD, tmp_path / "in.exr", "pool")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "pool [True, True, True, True]"


# ---- wrong results: NaN scored as perfect --------------------------------------

def test_measures_refuse_non_finite_images_and_numbers():
    img = samples()
    k = siproject.coefficients(img, factor=4)
    out = k.resample()
    bad = img.copy()
    bad[3, 4, 1] = np.nan
    worse = out.copy()
    worse[2, 1, 0] = np.inf
    cases = [
        (lambda: siproject.l2_error(k, bad), r"l2_error\(\): non-finite .* reference at x 4, y 3"),
        (lambda: siproject.Reference(bad), r"l2_error\(\): non-finite .* reference at x 4, y 3"),
        (lambda: siproject.l2_error(k, zoneplate=np.nan), r"K nan is not finite"),
        (lambda: siproject.l2_error(k, zoneplate=np.inf), r"K inf is not finite"),
        (lambda: siproject.l2_error(k, zoneplate=40, samples_per_pixel=10 ** 6),
         r"samples_per_pixel 1000000: expected 1 to 1024"),
        (lambda: siproject.rms_difference(out, worse), r"rms_difference\(\): non-finite .* second"),
        (lambda: siproject.rms_difference(worse, out), r"rms_difference\(\): non-finite .* first"),
        (lambda: siproject.psnr(out, worse), r"non-finite"),
        (lambda: siproject.psnr(out, out, peak=np.nan), r"peak"),
        (lambda: siproject.overshoot(worse, img), r"overshoot\(\): non-finite .* output at x 1, y 2"),
        (lambda: siproject.overshoot(out, bad), r"overshoot\(\): non-finite .* input at x 4, y 3"),
        (lambda: siproject.overshoot(out, img, tolerance=np.nan), r"tolerance"),
        (lambda: siproject.highpass_share(worse), r"non-finite"),
        (lambda: siproject.highpass_share(out, np.nan), r"cutoff"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError, match=message):
            call()
    # the hexagonal route too
    kh = siproject.coefficients(img, factor=4, lattice="hex")
    with pytest.raises(ValueError, match="reference"):
        siproject.l2_error(kh, bad)
    with pytest.raises(ValueError, match="not finite"):
        siproject.l2_error(kh, zoneplate=np.nan)


def test_overshoot_refuses_a_neighbourhood_past_the_output():
    code = """
        import numpy as np, siproject
        out, img = np.zeros((12, 16, 1), np.float32), np.zeros((48, 64, 1), np.float32)
        assert siproject.overshoot(out, img, neighbourhood=16)["pixels"] == 192
        try:
            siproject.overshoot(out, img, neighbourhood=1e300)
        except ValueError as e:
            print(e)
    """
    r = run_python(code, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == ("overshoot(): neighbourhood 1e+300 output pixels: at most 16 (the "
                                "output's larger side, where every pixel's neighbourhood holds "
                                "the whole input)")


def test_simetrics_refuses_a_neighbourhood_past_the_output(tmp_path):
    siproject.write_image(tmp_path / "in.exr", samples(64, 48))
    siproject.write_image(tmp_path / "out.exr", samples(16, 12))
    try:
        r = subprocess.run([SIMETRICS, str(tmp_path / "out.exr"), "--input", str(tmp_path / "in.exr"),
                            "--neighbourhood", "1e19"], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail("simetrics --neighbourhood 1e19 did not end")
    assert r.returncode == 2
    assert r.stdout == ""
    assert r.stderr == ("simetrics: overshoot(): neighbourhood 1e+19 output pixels: at most 16 (the "
                        "output's larger side, where every pixel's neighbourhood holds the whole "
                        "input)\n")


def test_write_image_half_clamps_past_65504_and_warns(tmp_path):
    import OpenEXR
    img = np.array([[[70000.0], [-1e6], [65504.0], [1.0], [np.inf], [-65504.0]]], np.float32)
    path = tmp_path / "h.exr"
    with pytest.warns(RuntimeWarning, match=r"half=True: 3 samples beyond \+-65504 clamped there"):
        siproject.write_image(path, img, half=True)
    with OpenEXR.File(str(path)) as f:
        (name, channel), = f.channels().items()
        assert channel.pixels.dtype == np.float16
        held = channel.pixels.astype(np.float32).ravel()
    assert held.tolist() == [65504.0, -65504.0, 65504.0, 1.0, 65504.0, -65504.0]
    with warnings.catch_warnings():  # within range: no warning
        warnings.simplefilter("error")
        siproject.write_image(path, img[:, 2:4], half=True)
        siproject.write_image(tmp_path / "f.exr", img)  # float holds them all


# ---- narrowing: channel counts past int ---------------------------------------

def test_channel_counts_past_int_are_refused():
    # no samples (a height of 0), so no memory: the count alone, not truncated
    empty = np.zeros((0, 1, 2 ** 32 + 3), np.float32)
    for call in (lambda: siproject.project(empty, factor=1),
                 lambda: siproject.rms_difference(empty, empty),
                 lambda: siproject.luminance(empty)):
        with pytest.raises(ValueError, match=r"4294967299 channels: at most 2147483647"):
            call()
    # refused before an 8 GB copy of a broadcast view is made
    wide = np.broadcast_to(np.float32(0.5), (1, 1, 2 ** 31))
    with pytest.raises(ValueError, match=r"2147483648 channels: at most 2147483647"):
        siproject.project(wide, factor=1)


# ---- type mistakes: one line naming the keyword -------------------------------

TYPE_MISTAKES = [
    ("project", dict(clamp=True), 'clamp=True: expected "none", "zero" or "local", not bool'),
    ("project", dict(generator=3), 'generator=3: expected "box", "tent"'),
    ("project", dict(display=2), 'display=2: expected "centred", "2x2", "pixel" or '
                                 '"offsets:DX,DY;..." or None, not int'),
    ("project", dict(highlight_compress="no"), "highlight_compress='no': expected True or False, not str"),
    ("project", dict(threads=1.5), "threads=1.5: expected a whole number (int), not float"),
    ("project", dict(threads=True), "threads=True: expected a whole number (int), not bool"),
    ("project", dict(factor=True), "factor=True: expected a number or None, not bool"),
    ("project", dict(factor="4"), "factor='4': expected a number or None, not str"),
    ("project", dict(density=True, lattice="hex"), "density=True: expected a number or None"),
    ("project", dict(size=(3.7, 2.2)), 'size=(3.7, 2.2): expected N, (width, height) or "WxH" of '
                                       'whole numbers, not tuple'),
    ("project", dict(size=True), 'size=True: expected N, (width, height) or "WxH", not bool'),
    ("project", dict(output_shape=(20, 2.5)), "output_shape=(20, 2.5): expected (rows, cols) of whole"),
    ("project", dict(output_shape=7), "output_shape=7: expected (rows, cols), not int"),
    ("project", dict(boundary=None), 'boundary=None: expected "mirror" or "periodic", not NoneType'),
    ("project", dict(method=1), 'method=1: expected "min-error" or "conventional" or None, not int'),
    ("project", dict(nonfinite=0), 'nonfinite=0: expected "error" or "zero", not int'),
    ("project", dict(prefilter=b"fft"), "prefilter=b'fft': expected \"fft\" or \"recursive\", not bytes"),
    ("project", dict(lattice=6), 'lattice=6: expected "cartesian" or "hex", not int'),
    ("coefficients", dict(threads="2"), "threads='2': expected a whole number (int), not str"),
    ("overshoot", dict(neighbourhood=True), "neighbourhood=True: expected a number, not bool"),
    ("overshoot", dict(border=1.0), "border=1.0: expected a whole number (int), not float"),
    ("l2_error", dict(zoneplate="40"), "zoneplate='40': expected a number or None, not str"),
    ("l2_error", dict(zoneplate=40, samples_per_pixel=8.0),
     "samples_per_pixel=8.0: expected a whole number (int), not float"),
    ("write_image", dict(half="yes"), "half='yes': expected True or False, not str"),
    ("write_image", dict(alpha=1.5), "alpha=1.5: expected a whole number (int), not float"),
    ("write_image", dict(channel_names="RGB"), "channel_names='RGB': expected a sequence of strings"),
    ("write_image", dict(dtype=3), 'dtype=3: expected "uint8", "uint16", "half", "float"'),
    ("write_image", dict(compression=9), 'compression=9: expected a string ("zip", "piz"'),
    ("write_image", dict(quality=50.0), "quality=50.0: expected a whole number 1 to 100 (int) or None, not float"),
    ("write_image", dict(quality=True), "quality=True: expected a whole number 1 to 100 (int) or None, not bool"),
]


@pytest.mark.parametrize("call,keywords,message", TYPE_MISTAKES,
                         ids=[f"{c}-{next(iter(k))}" for c, k, _ in TYPE_MISTAKES])
def test_type_mistakes_raise_one_line_naming_the_keyword(call, keywords, message, tmp_path):
    img = samples()
    if call == "project":
        f = lambda: siproject.project(img, **({"factor": 4} if "factor" not in keywords and
                                              "size" not in keywords and
                                              "output_shape" not in keywords else {}), **keywords)
    elif call == "coefficients":
        f = lambda: siproject.coefficients(img, factor=4, **keywords)
    elif call == "overshoot":
        f = lambda: siproject.overshoot(img[::4, ::4], img, **keywords)
    elif call == "l2_error":
        f = lambda: siproject.l2_error(siproject.coefficients(img, factor=4), **keywords)
    else:
        f = lambda: siproject.write_image(tmp_path / "o.exr", img, **keywords)
    with pytest.raises(TypeError) as e:
        f()
    text = str(e.value)
    assert text.startswith(message), text
    assert "\n" not in text and len(text) < 200, text
    assert not list(tmp_path.iterdir())


def test_a_long_value_is_named_by_its_type():
    img = samples()
    with pytest.raises(TypeError) as e:
        siproject.project(img, factor=4, clamp=img)
    assert str(e.value) == ('clamp=<ndarray of shape (48, 64, 3)>: expected "none", "zero" or '
                            '"local", not ndarray')


def test_numpy_scalars_are_taken_as_their_numbers():
    img = samples()
    expected = siproject.project(img, size=(16, 12), threads=2)
    assert np.array_equal(siproject.project(img, factor=np.float32(4), threads=np.int64(2)), expected)
    assert np.array_equal(siproject.project(img, size=(np.int32(16), np.int64(12))), expected)
    assert np.array_equal(siproject.project(img, output_shape=(np.int64(12), np.int64(16))),
                          expected)


def test_dir_shows_the_api_only():
    listed = dir(siproject)
    assert listed == sorted(siproject.__all__ + ["__version__"])
    for name in siproject.__all__:
        assert not name.startswith("_")
        assert getattr(siproject, name).__doc__
    r = subprocess.run([SIPROJECT, "--version"], capture_output=True, text=True)
    assert r.returncode == 0
    assert r.stdout.split()[:2] == ["siproject", siproject.__version__]


# ---- shapes ---------------------------------------------------------------------

def test_output_shape_is_rows_then_columns():
    img = samples(96, 64)  # not square: a transposition shows
    by_size = siproject.project(img, size=(30, 20))
    by_shape = siproject.project(img, output_shape=(20, 30))
    assert by_shape.shape == (20, 30, 3)
    assert np.array_equal(by_shape, by_size)
    small = img[::4, ::4]  # 16 x 24
    assert siproject.project(img, output_shape=small.shape[:2]).shape == small.shape
    k = siproject.coefficients(img, output_shape=(16, 24))
    assert k.frame == (24, 16)
    assert np.array_equal(k.resample(output_shape=(20, 30)), k.resample((30, 20)))
    with pytest.raises(ValueError, match=r"^give size=\(width, height\) or output_shape=\(rows, cols\), not both$"):
        siproject.project(img, size=(30, 20), output_shape=(20, 30))
    with pytest.raises(ValueError, match=r"^give factor or output_shape, not both$"):
        siproject.project(img, factor=4, output_shape=(20, 30))
    with pytest.raises(ValueError, match=r"^give size=\(width, height\) or output_shape"):
        k.resample((30, 20), output_shape=(20, 30))


# ---- Ctrl-C ---------------------------------------------------------------------

INTERRUPTED = """
    import os, signal, sys, threading, numpy as np, siproject
    # samples in a file mapped in memory, read where they are: the pages the
    # engine has read are the process's resident file pages (RssFile)
    path, H, W = sys.argv[1], 4096, 4096
    a = np.memmap(path, dtype=np.float32, mode="r", shape=(H, W, 1))

    def resident():
        for line in open("/proc/self/status"):
            if line.startswith("RssFile:"):
                return int(line.split()[1]) * 1024

    start = resident()

    def interrupt_once_a_tenth_is_read():
        while resident() - start < a.nbytes // 10:
            threading.Event().wait(0.001)
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=interrupt_once_a_tenth_is_read, daemon=True).start()
    completed = False
    try:
        siproject.project(a, factor=4, threads=2)
        completed = True
    except KeyboardInterrupt:
        print("KeyboardInterrupt", completed, round((resident() - start) / a.nbytes, 2))
    # the module goes on working, on every thread
    small = np.asarray(a[:400, :400])
    print(siproject.project(small, factor=4, threads=2).shape)
"""


def test_ctrl_c_interrupts_a_projection_at_once(tmp_path):
    path = tmp_path / "big.f32"
    with open(path, "wb") as f:  # 64 MB of zeros, a sparse file: no disk written
        f.truncate(4096 * 4096 * 4)
    r = run_python(INTERRUPTED, path, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.split("\n")
    kind, completed, read = lines[0].split()
    assert (kind, completed) == ("KeyboardInterrupt", "False")
    # the signal came once a tenth was read; a projection that ran on to its
    # end before answering would have read all of it (1.0). How far past a
    # tenth it got depends on when the watching thread was scheduled on a
    # loaded machine (0.51 seen with other builds running), so the bound is
    # the whole file less a margin for read-ahead, not a time
    assert 0.1 <= float(read) < 0.9, r.stdout
    assert lines[1] == "(100, 100, 1)"


# ---- signals during a write ---------------------------------------------------

WRITER = """
    import sys, numpy as np, siproject
    what, out = sys.argv[1], sys.argv[2]
    img = np.random.default_rng(2).random((1600, 1600, 3), dtype=np.float32)
    if what == "image":
        siproject.write_image(out, img)
    else:
        siproject.coefficients(img, factor=1, generator="box", method="conventional").save(out)
"""


def staged(folder):
    return glob.glob(os.path.join(folder, ".*.sis-*"))


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
@pytest.mark.parametrize("what", ["image", "coefficients"])
def test_a_signal_during_a_write_leaves_no_file(tmp_path, sig, what):
    """The writer is stopped the moment its staged file appears, sent the
    signal and let go: it ends by that signal, its staged file is gone and
    the file of the output's name is as it was."""
    out = tmp_path / "o.exr"
    caught = False
    for attempt in range(5):  # a stop after the rename is a lost race: tried again
        out.write_text("the old file")
        p = subprocess.Popen([sys.executable, "-c", textwrap.dedent(WRITER), what, str(out)])
        ended = False
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            if staged(tmp_path):
                os.kill(p.pid, signal.SIGSTOP)
                break
            if p.poll() is not None:
                ended = True
                break
            time.sleep(0.0002)
        if ended:
            continue
        caught = bool(staged(tmp_path))
        if caught:
            os.kill(p.pid, sig)
        os.kill(p.pid, signal.SIGCONT)
        status = p.wait(timeout=120)
        if caught:
            assert status == -sig
            assert staged(tmp_path) == []
            assert out.read_text() == "the old file"
            break
    assert caught, "the write was never caught in 5 runs"


def test_the_handlers_are_put_back_after_a_write(tmp_path):
    """Around a write the cleanup handlers stand in for the default actions
    only: SIGTERM is the default again afterwards, and a handler of Python's
    (SIGHUP here) is never replaced."""
    code = """
        import ctypes, os, signal, sys, numpy as np, siproject
        libc = ctypes.CDLL(None, use_errno=True)
        def action(sig):  # the handler field of the kernel's struct sigaction
            buf = ctypes.create_string_buffer(256)
            assert libc.sigaction(sig, None, buf) == 0
            return ctypes.c_void_p.from_buffer(buf).value or 0
        got = []
        signal.signal(signal.SIGHUP, lambda s, f: got.append(s))
        hup, term = action(signal.SIGHUP), action(signal.SIGTERM)
        siproject.write_image(sys.argv[1], np.zeros((8, 8, 3), np.float32))
        siproject.coefficients(np.zeros((8, 8, 3), np.float32), factor=2).save(sys.argv[1])
        os.kill(os.getpid(), signal.SIGHUP)
        print(term == 0, action(signal.SIGTERM) == term, action(signal.SIGHUP) == hup, got)
    """
    r = run_python(code, tmp_path / "o.exr")
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["True", "True", "True", f"[{int(signal.SIGHUP)}]"]


def test_resample_size_as_siproject_spells_it():
    """resample() reads a size as project() and siproject's --size do,
    against the coefficients' frame: a width alone keeps the aspect, 0 is
    the other side's, a percentage scales the frame."""
    k = siproject.coefficients(np.random.default_rng(3).random((40, 60, 3), dtype=np.float32),
                               factor=2)
    assert k.resample().shape == (20, 30, 3)
    assert np.array_equal(k.resample("15"), k.resample((15, 10)))
    assert np.array_equal(k.resample("0x10"), k.resample((15, 10)))
    assert np.array_equal(k.resample("50%"), k.resample((15, 10)))
    assert np.array_equal(k.resample(12), k.resample((12, 12)))
    with pytest.raises(ValueError, match=r"^--size 'x7': expected WxH"):
        k.resample("x7")
    with pytest.raises(ValueError, match="more than"):
        k.resample("3000000000x2")
