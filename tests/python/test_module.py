"""The Python module against siproject: the same images bit for bit, the same
errors, no copy of a float32 input, the GIL released while the engine works."""

import os
import subprocess
import sys
import textwrap
import threading

import numpy as np
import pytest

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")
SIMETRICS = os.environ.get("SIMETRICS", "simetrics")


def scene(w=96, h=80, c=3, seed=7):
    """Samples with smooth parts, edges and a highlight: every method differs."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    rng = np.random.default_rng(seed)
    img = np.empty((h, w, c), np.float32)
    for ch in range(c):
        img[:, :, ch] = (0.5 + 0.3 * np.sin(x / (5 + ch)) * np.cos(y / 7)
                         + 0.4 * ((x + 2 * y) % 23 < 9) + 0.05 * rng.random((h, w)))
    img[h // 3, w // 4] = 6.0
    return img


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("module")
    img = scene()
    f32, f16 = d / "in.exr", d / "in-half.exr"
    siproject.write_image(f32, img)
    siproject.write_image(f16, img, half=True)
    return {"dir": d, "float": f32, "half": f16, "image": img}


def run_siproject(*args, check=True):
    r = subprocess.run([SIPROJECT, *map(str, args), "-q"], capture_output=True, text=True)
    if check:
        assert r.returncode == 0, r.stderr
    return r


CASES = [
    # (siproject options, module keywords)
    ([], {}),
    (["--generator", "box", "--method", "conventional", "--display", "centred"],
     dict(generator="box", method="conventional", display="centred")),
    (["--generator", "tent", "--display", "centred"], dict(generator="tent", display="centred")),
    (["--generator", "mitchell"], dict(generator="mitchell")),
    (["--generator", "tent", "--display", "pixel", "--boundary", "periodic"],
     dict(generator="tent", display="pixel", boundary="periodic")),
    (["--display", "offsets:0.1,0.2;-0.3,0.1", "--highlight-compress", "--clamp", "local"],
     dict(display="offsets:0.1,0.2;-0.3,0.1", highlight_compress=True, clamp="local")),
    (["--lattice", "hex"], dict(lattice="hex")),
    (["--lattice", "hex", "--generator", "hex-hat", "--density", "1.3"],
     dict(lattice="hex", generator="hex-hat", density=1.3)),
]


@pytest.mark.parametrize("options,keywords", CASES, ids=[" ".join(c[0]) or "default" for c in CASES])
@pytest.mark.parametrize("kind", ["float", "half"])
def test_bit_identical_to_siproject_on_files_and_arrays(files, options, keywords, kind, tmp_path):
    out = tmp_path / "out.exr"
    run_siproject(files[kind], "-o", out, "--factor", "4", "-d", "float", *options)
    expected = siproject.read_image(out)
    from_file = siproject.project(files[kind], factor=4, **keywords)
    assert from_file.dtype == np.float32 and from_file.shape == expected.shape
    assert np.array_equal(from_file, expected)
    samples = files["image"] if kind == "float" else files["image"].astype(np.float16)
    from_array = siproject.project(samples, factor=4, **keywords)
    assert np.array_equal(from_array, expected)


def test_size_factor_and_threads(files, tmp_path):
    out = tmp_path / "out.exr"
    run_siproject(files["float"], "-o", out, "--size", "30x17", "--threads", "1")
    expected = siproject.read_image(out)
    for size in [(30, 17), "30x17"]:
        for threads in [1, 2, 3]:
            got = siproject.project(files["image"], size=size, threads=threads)
            assert np.array_equal(got, expected)


def test_grey_array_of_two_dimensions():
    """A 2-D array gives a 2-D result, the samples of the (H, W, 1) one's,
    which stays 3-D; so do resample() and srgb8()."""
    grey = scene(c=1)[:, :, 0]
    flat = siproject.project(grey, factor=2)
    deep = siproject.project(grey[:, :, np.newaxis], factor=2)
    assert flat.shape == (40, 48) and deep.shape == (40, 48, 1)
    assert np.array_equal(flat, deep[:, :, 0])
    k = siproject.coefficients(grey, factor=2)
    assert k.resample().shape == (40, 48) and np.array_equal(k.resample(), flat)
    assert siproject.coefficients(grey[:, :, np.newaxis], factor=2).resample().shape == (40, 48, 1)
    assert siproject.srgb8(flat).shape == (40, 48)
    assert np.array_equal(siproject.srgb8(flat), siproject.srgb8(deep)[:, :, 0])


def test_coefficients_resample_evaluate_save_load(files, tmp_path):
    img = files["image"]
    k = siproject.coefficients(img, factor=4)
    assert (k.lattice, k.generator, k.method, k.boundary) == ("cartesian", "cubic", "min-error", "mirror")
    assert k.frame == (24, 20)
    assert np.array_equal(k.resample(), siproject.project(img, factor=4))
    centred = k.resample(display="centred")
    x, y = np.meshgrid(np.arange(24) + 0.5, np.arange(20) + 0.5)
    at_centres = k.evaluate(x, y)
    assert at_centres.shape == (20, 24, 3)
    # evaluate() sums in double, the image is float: they agree to float's
    # rounding of the value (half an ulp, 2^-24 relative) and the summation
    # order of two routes over 16 terms (a few ulps of double).
    assert np.allclose(at_centres, centred, rtol=2.0 ** -23, atol=1e-7)
    # the coefficient file: written by save(), and equal to siproject --coeffs
    saved = tmp_path / "k.exr"
    k.save(saved)
    theirs = tmp_path / "theirs.exr"
    run_siproject(files["float"], "-o", tmp_path / "o.exr", "--factor", "4", "--coeffs", theirs)
    assert np.array_equal(siproject.load(saved).array, siproject.load(theirs).array)
    assert np.array_equal(k.array, siproject.load(theirs).array)
    out = tmp_path / "eval.exr"
    run_siproject(theirs, "-o", out, "--size", "48x40", "--display", "pixel", "-d", "float")
    assert np.array_equal(siproject.load(saved).resample((48, 40), display="pixel"),
                          siproject.read_image(out))
    assert np.array_equal(siproject.project(saved, size=(48, 40), display="pixel"),
                          siproject.read_image(out))


def test_hexagonal_coefficients_evaluate_at_their_lattice_points():
    k = siproject.coefficients(scene(), factor=4, lattice="hex")
    assert k.lattice == "hexagonal" and k.generator == "hex-quartic"
    img = k.resample(display="centred")
    x, y = np.meshgrid(np.arange(24) + 0.5, np.arange(20) + 0.5)
    assert np.allclose(k.evaluate(x, y), img, rtol=2.0 ** -23, atol=1e-7)


def siproject_message(*options, input_path):
    r = run_siproject(input_path, "-o", "/tmp/never-written.exr", *options, check=False)
    assert r.returncode != 0
    assert r.stderr.startswith("siproject: ")
    return r.stderr[len("siproject: "):].strip()


@pytest.mark.parametrize("options,keywords", [
    (["--factor", "4", "--generator", "foo"], dict(factor=4, generator="foo")),
    (["--factor", "4", "--method", "min-error", "--generator", "mitchell"],
     dict(factor=4, method="min-error", generator="mitchell")),
    (["--factor", "0"], dict(factor=0)),
    (["--size", "0x0"], dict(size="0x0")),
    (["--factor", "4", "--size", "3x3"], dict(factor=4, size=(3, 3))),
    (["--factor", "4", "--display", "sideways"], dict(factor=4, display="sideways")),
    (["--factor", "4", "--density", "2"], dict(factor=4, density=2)),
    (["--factor", "4", "--lattice", "hex", "--prefilter", "recursive"],
     dict(factor=4, lattice="hex", prefilter="recursive")),
    (["--factor", "4", "--clamp", "maybe"], dict(factor=4, clamp="maybe")),
    (["--factor", "4", "--threads", "-1"], dict(factor=4, threads=-1)),
    (["--factor", "1000"], dict(factor=1000)),
    ([], {}),
])
def test_bad_options_raise_value_error_with_siprojects_message(files, options, keywords):
    expected = siproject_message(*options, input_path=files["float"])
    with pytest.raises(ValueError) as e:
        siproject.project(files["float"], **keywords)
    assert str(e.value) == expected


def test_files_raise_os_error_with_siprojects_message(files, tmp_path):
    missing = tmp_path / "missing.exr"
    expected = siproject_message("--factor", "4", input_path=missing)
    with pytest.raises(OSError) as e:
        siproject.project(missing, factor=4)
    assert str(e.value) == expected
    truncated = tmp_path / "truncated.exr"
    truncated.write_bytes(files["float"].read_bytes()[:2000])
    expected = siproject_message("--factor", "4", input_path=truncated)
    with pytest.raises(OSError) as e:
        siproject.project(truncated, factor=4)
    assert str(e.value) == expected
    with pytest.raises(OSError):
        siproject.load(missing)


def test_arrays_with_non_finite_samples():
    img = scene()
    img[5, 9, 1] = np.nan
    with pytest.raises(ValueError, match="array: non-finite sample"):
        siproject.project(img, factor=4)
    with pytest.warns(RuntimeWarning, match="replaced 1 non-finite samples with 0"):
        got = siproject.project(img, factor=4, nonfinite="zero")
    img[5, 9, 1] = 0
    assert np.array_equal(got, siproject.project(img, factor=4))
    with pytest.raises(ValueError):
        siproject.project(np.zeros((0, 4, 3), np.float32), factor=1)
    with pytest.raises(ValueError):
        siproject.project(np.zeros((4, 4, 3), np.complex64), factor=1)


def test_metrics_equal_simetrics(files, tmp_path):
    import json
    out = tmp_path / "out.exr"
    run_siproject(files["float"], "-o", out, "--factor", "4", "-d", "float", "--coeffs", tmp_path / "k.exr")
    r = subprocess.run([SIMETRICS, str(out), "--cutoff", "0.125", "0.25", "--input", str(files["float"]),
                        "--coeffs", str(tmp_path / "k.exr"), "--zoneplate", "40", "--json"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    m = json.loads(r.stdout)
    image = siproject.read_image(out)
    shares = siproject.highpass_share(image, [0.125, 0.25])
    # one code path: equal to the digits simetrics prints (17 significant)
    assert shares == [m["hp_0.125"], m["hp_0.25"]]
    k = siproject.load(tmp_path / "k.exr")
    assert siproject.l2_error(k, zoneplate=40) == m["continuous"]["l2_error"]
    o = siproject.overshoot(image, files["image"])
    assert o["max_overshoot"] == m["overshoot"]["max_overshoot"]
    assert o["pixels_out_of_range"] == m["overshoot"]["pixels_out_of_range"]


def test_reference_keeps_its_acquisitions(files):
    """A Reference gives l2_error's bits for every approximation, reads a
    float32 array where it is, and refuses a second border."""
    truth = siproject.read_image(files["float"])
    ref = siproject.Reference(truth, border=2)
    assert np.shares_memory(ref.array, truth)
    small = truth[::4, ::4].copy()
    for generator in ("box", "tent", "cubic", "cubic"):  # the last from the kept acquisition
        k = siproject.coefficients(small, factor=1, generator=generator)
        assert ref.l2_error(k) == siproject.l2_error(k, truth, border=2)
        assert siproject.l2_error(k, ref) == ref.l2_error(k)
    hex_k = siproject.coefficients(small, factor=1, lattice="hex")
    assert ref.l2_error(hex_k) == siproject.l2_error(hex_k, truth, border=2)
    with pytest.raises(ValueError, match="border 3 given with a Reference made with border 2"):
        siproject.l2_error(k, ref, border=3)
    with pytest.raises(ValueError, match="border 0 given with a Reference made with border 2"):
        siproject.l2_error(k, ref, border=0)
    assert siproject.l2_error(k, ref, border=2) == ref.l2_error(k)
    with pytest.raises(ValueError, match="border -1"):
        siproject.Reference(truth, border=-1)
    with pytest.raises(ValueError, match="channels"):
        ref.l2_error(siproject.coefficients(small[:, :, :1], factor=1))


def test_float32_input_is_not_copied(tmp_path):
    """A 4000 x 4000 float32 array projects with a peak well below a second copy."""
    code = textwrap.dedent("""
        import resource, numpy as np, siproject
        a = np.full((4000, 4000, 3), 0.5, np.float32)   # 192 MB, every page touched
        a[::7, ::5, 1] = 0.25
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        image = siproject.project(a, factor=4, threads=2)
        after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        print(a.nbytes, after - before)
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env={**os.environ})
    assert r.returncode == 0, r.stderr
    nbytes, growth = map(int, r.stdout.split())
    # The engine's own memory at 1000 x 1000 x 3 is the coefficients (24 MB
    # of double), the local range, the image and per-thread strips: well
    # under half the input; a copy of the input would add all of its 192 MB.
    assert growth < nbytes / 2, f"peak grew by {growth / 2**20:.0f} MiB for a {nbytes / 2**20:.0f} MiB input"


def test_the_gil_is_released_while_the_engine_works():
    """Another Python thread runs while project() is inside the engine: with a
    switch interval longer than the call, it can run only if the call lets
    go of the GIL."""
    img = np.random.default_rng(3).random((1200, 1200, 3), dtype=np.float32)
    counter = [0]
    done = threading.Event()

    def spin():
        import time
        while not done.is_set():
            counter[0] += 1
            time.sleep(0)  # lets go of the GIL each time round: the main thread goes on

    old = sys.getswitchinterval()
    sys.setswitchinterval(100.0)
    t = threading.Thread(target=spin)
    try:
        t.start()
        before = counter[0]
        siproject.project(img, factor=3, threads=1)
        during = counter[0] - before
    finally:
        done.set()
        t.join()
        sys.setswitchinterval(old)
    assert during > 0


def test_help_shows_every_option_with_its_default():
    import inspect
    sig = inspect.signature(siproject.project)
    for name in ["size", "factor", "generator", "method", "display", "boundary", "lattice",
                 "density", "nonfinite", "prefilter", "clamp",
                 "highlight_compress", "threads"]:
        assert name in sig.parameters
        assert name in siproject.project.__doc__
    assert sig.parameters["boundary"].default == "mirror"
    assert sig.parameters["threads"].default == 0


def test_srgb8_is_what_an_8bit_file_holds(tmp_path):
    from PIL import Image
    img = scene()
    img[0, :8, 0] = [-1, 0, 0.0031308, 0.5, 0.999, 1, 2, np.inf]
    png = tmp_path / "out.png"
    siproject.write_image(png, img)
    held = np.asarray(Image.open(png))
    assert np.array_equal(siproject.srgb8(img), held)


@pytest.mark.parametrize("size,shape", [
    ("50%", (40, 48)), ("48", (40, 48)), ("48x0", (40, 48)), ("0x40", (40, 48)), ("25%x50%", (40, 24)),
])
def test_size_strings_as_siproject_spells_them(files, size, shape):
    # the same parser as siproject's --size: oiiotool's spellings, the same images
    out = files["dir"] / "size.exr"
    a = siproject.project(files["float"], size=size)
    assert a.shape == shape + (3,)
    run_siproject(files["float"], "-o", out, "--size", size, "-d", "float")
    assert np.array_equal(a, siproject.read_image(out))


@pytest.mark.parametrize("alias,canonical", [
    (dict(generator="triangle"), dict(generator="tent")),
    (dict(display="center"), dict(display="centred")),
    (dict(display="centre"), dict(display="centred")),
    (dict(lattice="hexagonal"), dict(lattice="hex")),
])
def test_name_aliases_give_the_canonical_names_images(files, alias, canonical):
    assert np.array_equal(siproject.project(files["float"], factor=4, **alias),
                          siproject.project(files["float"], factor=4, **canonical))
