"""Scattered samples from Python (values at positions=) and through siproject
(an OpenEXR file with position channels pFilm.x, pFilm.y): against a slow
direct numpy reference, flat images, the grid's own positions, the integer
rule, the errors; files from two writers against the module."""

import os
import subprocess

import numpy as np
import OpenEXR
import pytest

import siproject

SIPROJECT = os.environ.get("SIPROJECT", "siproject")


def bspline3(t):
    t = np.abs(t)
    return np.where(t < 1, 2 / 3 - t ** 2 + t ** 3 / 2, np.where(t < 2, (2 - t) ** 3 / 6, 0.0))


def axis_weights(x, L):
    """phi(image - (n + 1/2)) summed over the mirror images +-x + 2 L k of each
    position: (N, L). Positions within [0, L] and L >= 4 need k in -1..1."""
    centres = np.arange(L) + 0.5
    w = np.zeros((len(x), L))
    for k in (-1, 0, 1):
        for image in (x + 2 * L * k, -x + 2 * L * k):
            w += bspline3(image[:, None] - centres[None, :])
    return w


def mirror_gram(L):
    """The cubic's autocorrelation a[k] = B7(k) on the half-sample mirror
    extension: (A c)[n] = sum_k a[k] c[fold(n - k)], a dense L x L matrix."""
    a = {0: 2416 / 5040, 1: 1191 / 5040, 2: 120 / 5040, 3: 1 / 5040}
    A = np.zeros((L, L))
    for n in range(L):
        for k in range(-3, 4):
            m = n - k
            while not 0 <= m < L:
                m = -m - 1 if m < 0 else 2 * L - 1 - m
            A[n, m] += a[abs(k)]
    return A


def normalised_reference(values, positions, weights, W, H):
    """The normalised rule by direct double sums over every sample and
    coefficient, then the prefilter as a dense solve: (H, W, C)."""
    wx = axis_weights(positions[:, 0], W)  # (N, W)
    wy = axis_weights(positions[:, 1], H)  # (N, H)
    phi = wy[:, :, None] * wx[:, None, :]  # (N, H, W)
    den = np.einsum("i,iyx->yx", weights, phi)
    r = np.einsum("i,iyx,ic->yxc", weights, phi, values) / den[:, :, None]
    Ax, Ay = mirror_gram(W), mirror_gram(H)
    return np.stack([np.linalg.solve(Ay, np.linalg.solve(Ax, r[:, :, c].T).T)
                     for c in range(values.shape[1])], axis=2)


def one_float_ulp(reference):
    # The module keeps coefficients in float (rounding to nearest: half an
    # ulp of float); the sums' own double rounding is of order 1e-15, far
    # below: one ulp of float at each value bounds both.
    return np.spacing(np.abs(reference).astype(np.float32)).astype(np.float64)


def test_normalised_sum_equals_a_direct_numpy_reference():
    rng = np.random.default_rng(5)
    W, H, N = 9, 7, 400
    positions = rng.random((N, 2)) * [W, H]  # the whole frame: the mirror folding is in play
    # float32 values (the module converts float64 ones to float32, as for a grid)
    values = (rng.random((N, 2)) - 0.3).astype(np.float32)
    weights = 0.5 + rng.random(N)
    k = siproject.coefficients(values, positions=positions, weights=weights, size=(W, H),
                               rule="normalised")
    ref = normalised_reference(values.astype(np.float64), positions, weights, W, H)
    assert k.array.shape == ref.shape
    assert np.all(np.abs(k.array - ref) <= one_float_ulp(ref))
    # None: the frame's area / N each, the same as equal weights
    equal = siproject.coefficients(values, positions=positions, size=(W, H), rule="normalised")
    ref = normalised_reference(values.astype(np.float64), positions, np.full(N, W * H / N), W, H)
    assert np.all(np.abs(equal.array - ref) <= one_float_ulp(ref))
    assert k.report["rule"] == "normalised" and k.report["passes"] == 1


@pytest.mark.parametrize("rule", ["fit", "normalised"])
def test_a_flat_image_from_random_positions_comes_back_flat(rule):
    rng = np.random.default_rng(11)
    W, H, N = 40, 30, 40 * 30 * 3
    positions = rng.random((N, 2)) * [W, H]
    values = np.full((N, 3), 0.3)
    weights = 0.2 + rng.random(N)
    image = siproject.project(values, positions=positions, weights=weights, size=(W, H), rule=rule)
    assert image.shape == (H, W, 3)
    # The coefficients are float(0.3) to double rounding, kept in float; the
    # 2x2 display sums 4 x 16 of them in double and rounds to float: within
    # one ulp of float(0.3).
    assert np.abs(image - np.float32(0.3)).max() <= np.spacing(np.float32(0.3))
    k = siproject.coefficients(values, positions=positions, weights=weights, size=(W, H), rule=rule)
    assert np.abs(k.array - np.float32(0.3)).max() <= np.spacing(np.float32(0.3))
    if rule == "fit":
        assert k.report["iterations"] <= 5 and max(k.report["residual"]) < 1e-12


@pytest.mark.parametrize("rule", ["normalised", "plain"])
def test_samples_at_the_grids_own_positions_give_the_grid_projection(rule):
    rng = np.random.default_rng(2)
    W, H, s = 12, 10, 4
    grid = rng.random((H * s, W * s, 3)).astype(np.float32)
    y, x = np.mgrid[0:H * s, 0:W * s]
    positions = np.stack([(x.ravel() + 0.5) / s, (y.ravel() + 0.5) / s], axis=1)
    values = grid.reshape(-1, 3)
    expected = siproject.coefficients(grid, size=(W, H)).array
    for weights in (None, np.full(len(values), 1.0 / (s * s))):
        k = siproject.coefficients(values, positions=positions, weights=weights, size=(W, H),
                                   rule=rule)
        # Both are the sums of the same products in other orders (the grid's
        # separable tables, the scattered taps): double rounding of order
        # 1e-16, then the same prefilter and float: one ulp of float.
        assert np.all(np.abs(k.array - expected) <= one_float_ulp(expected))
    # the image too, in two dimensions from values of one
    image = siproject.project(values[:, 0], positions=positions, size=(W, H), rule=rule,
                              display="centred")
    grid_image = siproject.project(grid[:, :, 0], size=(W, H), display="centred")
    assert image.shape == grid_image.shape == (H, W)
    assert np.abs(image - grid_image).max() <= 4 * np.spacing(np.abs(grid_image).max())


def test_uint8_values_follow_the_integer_rule(tmp_path):
    rng = np.random.default_rng(4)
    N = 16 * 16 * 4
    codes = rng.integers(0, 256, (N, 3), dtype=np.uint8)
    positions = rng.random((N, 2)) * 16
    # the linear values the same codes in an 8-bit file read as
    siproject.write_image(tmp_path / "codes.png", codes.reshape(32, 32, 3))
    linear = siproject.read_image(tmp_path / "codes.png").reshape(N, 3)
    assert not np.array_equal(linear, codes / np.float32(255))  # decoded, not only scaled
    from_codes = siproject.project(codes, positions=positions, size=16)
    assert np.array_equal(from_codes, siproject.project(linear, positions=positions, size=16))
    as_linear = siproject.project(codes, positions=positions, size=16, input_transfer="linear")
    assert not np.array_equal(as_linear, from_codes)
    codes16 = (codes.astype(np.uint16) * 257)  # the same levels in 16 bits
    assert np.allclose(siproject.project(codes16, positions=positions, size=16), from_codes,
                       rtol=0, atol=1e-6)


def test_report_and_iterations():
    rng = np.random.default_rng(8)
    N = 24 * 24 * 4
    positions = rng.random((N, 2)) * 24
    values = np.sin(positions[:, :1] / 3) * np.cos(positions[:, 1:] / 4)
    one = siproject.coefficients(values, positions=positions, size=24, iterations=1)
    assert one.report["rule"] == "fit" and one.report["iterations"] == 1
    assert one.report["passes"] == 5 and one.report["bytes"] > 0
    assert len(one.report["residual"]) == 1
    more = siproject.coefficients(values, positions=positions, size=24, iterations=20)
    assert more.report["residual"][0] < one.report["residual"][0]
    assert siproject.coefficients(np.ones((8, 8)), size=4).report is None
    conventional = siproject.coefficients(values, positions=positions, size=24, generator="tent",
                                          method="conventional")
    assert conventional.report["rule"] == "normalised" and conventional.method == "conventional"


N_BAD = 64
_P = np.random.default_rng(0).random((N_BAD, 2)) * 8
_V = np.ones((N_BAD, 3))


def _with(array, index, value):
    a = array.copy()
    a[index] = value
    return a


BAD = [
    (dict(values=_V, positions=_P), "size=: scattered samples need the frame"),
    (dict(values=_V, positions=_P, factor=2), "factor=: scattered samples have no grid"),
    (dict(values=_V, positions=_P[:, :1], size=8), r"positions: expected \(N, 2\)"),
    (dict(values=_V, positions=_P[:-1], size=8), "positions: 63 rows for 64 samples"),
    (dict(values=_V.reshape(8, 8, 3), positions=_P, size=8), r"values: with positions=, expected \(N,\) or \(N, channels\)"),
    (dict(values=_V, positions=_P.astype(str), size=8), "positions: of type"),
    (dict(values=_V, positions=_P, size=8, weights=np.ones(3)), "weights: 3 for 64 samples"),
    (dict(values=_V, positions=_P, size=8, weights=np.ones((64, 1))), r"weights: expected \(N,\)"),
    (dict(values=_V, positions=_with(_P, (5, 0), np.nan), size=8), r"positions: row 5: position \(nan, .*\) is not finite"),
    (dict(values=_V, positions=_with(_P, (7, 1), 8.5), size=8), r"positions: row 7: position \(.*, 8\.5\) lies outside the frame \[0, 8\] x \[0, 8\]"),
    (dict(values=_V, positions=_with(_P, (2, 0), -0.25), size=8), r"positions: row 2: position \(-0\.25, .*\) lies outside the frame"),
    (dict(values=_with(_V, (9, 1), np.inf), positions=_P, size=8), r"values: row 9: non-finite value \(NaN or Inf\) in channel G"),
    (dict(values=_V, positions=_P, size=8, weights=_with(np.ones(64), 3, 0.0)), r"weights: row 3: weight 0 \(the area a sample stands for: finite and > 0\)"),
    (dict(values=_V, positions=_P, size=8, weights=_with(np.ones(64), 4, np.nan)), r"weights: row 4: weight nan"),
    (dict(values=_V, positions=_P, size=8, rule="best"), r"--rule 'best': expected fit, normalised, plain or variational"),
    (dict(values=_V, positions=_P, size=8, iterations=-1), r"--iterations -1: expected 0 or more"),
    (dict(values=_V, positions=_P, size=8, clamp="local"), r"--clamp local: values: scattered samples have no local range"),
    (dict(values=_V, positions=_P, size="50%"), r"--size 50%: values: scattered samples need the frame as --size WxH in pixels"),
    (dict(values=_V, positions=_P, size=8, method="conventional", generator="tent", rule="fit"), r"--rule fit: the conventional method takes the normalised weighted average"),
    (dict(values=np.ones((8, 8)), size=4, rule="fit"), r"--rule applies to scattered samples"),
    (dict(values=np.ones((8, 8)), size=4, weights=np.ones(64)), r"weights= goes with positions="),
]


@pytest.mark.parametrize("keywords,message", BAD, ids=[m[:40] for _, m in BAD])
def test_bad_scattered_input_is_a_one_line_value_error_naming_the_keyword(keywords, message):
    keywords = dict(keywords)
    values = keywords.pop("values")
    with pytest.raises(ValueError, match=message) as e:
        siproject.project(values, **keywords)
    assert "\n" not in str(e.value)


def test_wrong_keyword_types_are_type_errors():
    with pytest.raises(TypeError, match=r'rule=3: expected "fit", "normalised" or "plain" or None'):
        siproject.project(_V, positions=_P, size=8, rule=3)
    with pytest.raises(TypeError, match=r"iterations=2\.5: expected a whole number"):
        siproject.project(_V, positions=_P, size=8, iterations=2.5)


# ---- siproject: an OpenEXR file with position channels


def scattered_arrays(W=20, H=14, per_pixel=3, seed=9, weighted=True):
    """Samples in float32 (as the files hold them): positions, values, weights."""
    rng = np.random.default_rng(seed)
    N = W * H * per_pixel
    positions = (rng.random((N, 2)) * [W, H]).astype(np.float32)
    x, y = positions[:, 0].astype(np.float64), positions[:, 1].astype(np.float64)
    values = np.stack([0.5 + 0.4 * np.sin(x / 2) * np.cos(y / 3), 0.2 + 0.01 * x, 0.7 - 0.02 * y],
                      axis=1).astype(np.float32)
    weights = (0.5 + rng.random(N)).astype(np.float32) * (W * H / N) if weighted else None
    return positions, values, weights


def write_with_the_projects_writer(path, positions, values, weights, shape):
    channels = [values, positions]
    names = ["R", "G", "B", "pFilm.x", "pFilm.y"]
    if weights is not None:
        channels.append(weights[:, None])
        names.append("weight")
    siproject.write_image(path, np.concatenate(channels, axis=1).reshape(*shape, len(names)),
                          channel_names=names)


def write_with_openexr(path, positions, values, weights, shape, origin=(0, 0)):
    """OpenEXR's own Python binding, a data window away from the origin."""
    h, w = shape
    channels = {"R": values[:, 0], "G": values[:, 1], "B": values[:, 2],
                "pFilm.x": positions[:, 0], "pFilm.y": positions[:, 1]}
    if weights is not None:
        channels["weight"] = weights
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
              "dataWindow": (np.array(origin, np.int32), np.array((origin[0] + w - 1, origin[1] + h - 1), np.int32)),
              "displayWindow": (np.array((0, 0), np.int32), np.array((origin[0] + w + 3, origin[1] + h + 2), np.int32))}
    with OpenEXR.File(header, {k: np.ascontiguousarray(v.reshape(h, w)) for k, v in channels.items()}) as f:
        f.write(str(path))


def siproject_run(*args):
    return subprocess.run([SIPROJECT, *map(str, args)], capture_output=True, text=True)


@pytest.mark.parametrize("weighted", [True, False], ids=["weight channel", "no weight channel"])
@pytest.mark.parametrize("rule", ["fit", "normalised"])
def test_a_position_channel_file_from_two_writers_gives_the_modules_image(tmp_path, rule, weighted):
    positions, values, weights = scattered_arrays(weighted=weighted)
    N = len(values)
    ours, theirs = tmp_path / "ours.exr", tmp_path / "theirs.exr"
    write_with_the_projects_writer(ours, positions, values, weights, (N // 30, 30))
    write_with_openexr(theirs, positions, values, weights, (N // 40, 40), origin=(5, 7))
    expected = siproject.project(values, positions=positions, weights=weights, size=(20, 14),
                                 rule=rule)
    for path in (ours, theirs):
        out = tmp_path / f"out-{path.stem}.exr"
        r = siproject_run(path, "-o", out, "--size", "20x14", "--rule", rule)
        assert r.returncode == 0 and r.stderr == "", r.stderr
        got = siproject.read_image(out)
        assert np.array_equal(got, expected), path.name
        # the module reads the file the same way
        assert np.array_equal(siproject.project(path, size=(20, 14), rule=rule), expected)


def test_a_position_channel_file_with_options(tmp_path):
    positions, values, weights = scattered_arrays()
    path = tmp_path / "s.exr"
    write_with_openexr(path, positions, values, weights, (len(values) // 40, 40))
    out, coeffs = tmp_path / "o.png", tmp_path / "k.exr"
    r = siproject_run(path, "-o", out, "--size", "20x14", "--iterations", "2", "--coeffs", coeffs,
                      "--display", "centred", "-v")
    assert r.returncode == 0, r.stderr
    assert "840 scattered samples x 3 -> 20 x 14" in r.stderr
    assert "rule fit: 7 passes, 2 iterations, residual" in r.stderr
    k = siproject.load(coeffs)
    expected = siproject.coefficients(values, positions=positions, weights=weights, size=(20, 14),
                                      iterations=2)
    assert np.array_equal(k.array, expected.array)
    assert siproject.read_image(out).shape == (14, 20, 3)  # 8-bit sRGB, read back linear


def test_bad_position_channel_files_exit_non_zero_naming_the_file(tmp_path):
    positions, values, weights = scattered_arrays()
    h, w = len(values) // 40, 40

    def openexr(name, channels):
        path = tmp_path / name
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with OpenEXR.File(header, {k: np.ascontiguousarray(v.reshape(h, w)) for k, v in channels.items()}) as f:
            f.write(str(path))
        return path

    rgb = {"R": values[:, 0], "G": values[:, 1], "B": values[:, 2]}
    outside = positions.copy()
    outside[17] = [20.5, 3.0]
    nan_value = values[:, 0].copy()
    nan_value[33] = np.nan
    nan_position = positions[:, 1].copy()
    nan_position[45] = np.nan
    cases = [
        (openexr("only-x.exr", {**rgb, "pFilm.x": positions[:, 0]}), 3,
         "only-x.exr: has the position channel pFilm.x but not pFilm.y"),
        (openexr("only-y.exr", {**rgb, "pFilm.y": positions[:, 1]}), 3,
         "only-y.exr: has the position channel pFilm.y but not pFilm.x"),
        (openexr("outside.exr", {**rgb, "pFilm.x": outside[:, 0], "pFilm.y": outside[:, 1]}), 3,
         r"outside.exr: pFilm.x, pFilm.y: pixel \(17, 0\): position \(20.5, 3\) lies outside the frame \[0, 20\] x \[0, 14\]"),
        (openexr("nan-value.exr", {"R": nan_value, "G": values[:, 1], "B": values[:, 2],
                                   "pFilm.x": positions[:, 0], "pFilm.y": positions[:, 1]}), 3,
         r"nan-value.exr: pixel \(33, 0\): non-finite value \(NaN or Inf\) in channel R; use --nonfinite zero"),
        (openexr("nan-position.exr", {**rgb, "pFilm.x": positions[:, 0], "pFilm.y": nan_position}), 3,
         r"nan-position.exr: pFilm.x, pFilm.y: pixel \(5, 1\): position \(.*, nan\) is not finite"),
        (openexr("bad-weight.exr", {**rgb, "pFilm.x": positions[:, 0], "pFilm.y": positions[:, 1],
                                    "weight": -np.ones(h * w, np.float32)}), 3,
         r"bad-weight.exr: weight: pixel \(0, 0\): weight -1"),
        (openexr("int-position.exr", {**rgb, "pFilm.x": (positions[:, 0] * 100).astype(np.uint32),
                                      "pFilm.y": positions[:, 1]}), 3,
         "int-position.exr: channel pFilm.x is stored as uint; positions and weights are float or half"),
        (openexr("no-values.exr", {"pFilm.x": positions[:, 0], "pFilm.y": positions[:, 1]}), 3,
         "no-values.exr: no value channel beside pFilm.x, pFilm.y"),
    ]
    import re
    for path, status, message in cases:
        out = tmp_path / "out.exr"
        r = siproject_run(path, "-o", out, "--size", "20x14")
        assert r.returncode == status, (path.name, r.stderr)
        assert re.search(message, r.stderr), (path.name, r.stderr)
        # nothing but the inputs: no output, no staged file
        assert sorted(p.name for p in tmp_path.iterdir()) == sorted(c[0].name for c in cases)
    good = openexr("good.exr", {**rgb, "pFilm.x": positions[:, 0], "pFilm.y": positions[:, 1]})
    for options, message in [
            (["--factor", "2"], "--factor: good.exr: scattered samples have no grid to divide"),
            (["--scale", "0.5"], "--scale: good.exr: scattered samples have no grid"),
            (["--size", "20x14", "--partial"], "good.exr: a file of scattered samples .* has no row bands; --partial takes a grid's bands"),
            (["--size", "20x14", "--merge"], "--merge: good.exr is not a partial file"),
            (["--size", "20", "--rule", "fit"], "--size 20: good.exr: scattered samples need the frame as --size WxH in pixels"),
            (["--size", "20x14", "--clamp", "local"], "--clamp local: good.exr: scattered samples have no local range")]:
        out = tmp_path / "out.exr"
        r = siproject_run(good, "-o", out, *options)
        assert r.returncode == 2, (options, r.stderr)
        assert re.search(message, r.stderr), (options, r.stderr)
        assert not out.exists()
    r = siproject_run(good, good, "--bands", "-o", tmp_path / "out.exr", "--size", "20x14")
    assert r.returncode == 2 and "is projected alone, not as a band or with other inputs" in r.stderr
    # a grid input refuses the scattered options
    grid = tmp_path / "grid.exr"
    siproject.write_image(grid, np.ones((8, 8, 3), np.float32))
    r = siproject_run(grid, "-o", tmp_path / "out.exr", "--factor", "2", "--rule", "normalised")
    assert r.returncode == 2 and "--rule applies to scattered samples" in r.stderr
    # NaN values replaced with --nonfinite zero, said on stderr
    r = siproject_run(tmp_path / "nan-value.exr", "-o", tmp_path / "out.exr", "--size", "20x14",
                      "--nonfinite", "zero")
    assert r.returncode == 0 and "replaced 1 non-finite values with 0" in r.stderr


@pytest.mark.parametrize("generator", ["hex-hat", "hex-quartic"])
@pytest.mark.parametrize("rule", ["fit", "normalised"])
def test_an_oiiotool_file_of_a_flat_image_stays_flat_on_the_hexagonal_lattice(tmp_path, rule, generator):
    # A file written by OpenImageIO's oiiotool: 64 x 48 samples of a flat
    # colour, their positions a gradient across a 20 x 14 frame plus
    # OpenImageIO's seeded uniform noise (so not a grid), in float.
    samples = tmp_path / "samples.exr"
    r = subprocess.run(
        ["oiiotool", "--pattern", "constant:color=0.3,0.6,0.9", "64x48", "3",
         "--pattern", "fill:left=0.05:right=19.6", "64x48", "1",
         "--pattern", "noise:type=uniform:min=0:max=0.35:seed=3", "64x48", "1", "--add",
         "--pattern", "fill:top=0.05:bottom=13.6", "64x48", "1",
         "--pattern", "noise:type=uniform:min=0:max=0.35:seed=4", "64x48", "1", "--add",
         "--chappend", "--chappend", "--chnames", "R,G,B,pFilm.x,pFilm.y", "-d", "float",
         "-o", str(samples)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "out.exr"
    coeffs = tmp_path / "coeffs.exr"
    r = siproject_run(samples, "-o", out, "--size", "20x14", "--lattice", "hex", "--generator",
                      generator, "--rule", rule, "-d", "float", "--coeffs", coeffs)
    assert r.returncode == 0, r.stderr
    image = siproject.read_image(out)
    assert image.shape == (14, 20, 3)
    want = np.array([0.3, 0.6, 0.9], np.float32)
    # The coefficients are the colour to double rounding (normalised sums,
    # the hexagonal prefilter's FFT, the fit's residual zero from its start)
    # kept in float; the 2x2 display sums the box spline's weights (1 to
    # rounding) in double and rounds to float: within one ulp of float.
    assert np.abs(image - want).max() <= np.spacing(want).max()
    # the coefficient file is a hexagonal grid's, flat, and evaluates to the
    # same image without the samples
    k = siproject.load(coeffs)
    assert (k.lattice, k.generator) == ("hexagonal", generator)
    assert np.abs(k.array - want).max() <= np.spacing(want).max()
    again = tmp_path / "again.exr"
    r = siproject_run(coeffs, "-o", again, "-d", "float")
    assert r.returncode == 0, r.stderr
    assert np.array_equal(siproject.read_image(again), image)
    # the module, on the same samples as arrays, gives the tool's image
    pix = siproject.read_image(samples)
    values, positions = pix[..., :3].reshape(-1, 3), pix[..., 3:].reshape(-1, 2).astype(np.float64)
    module = siproject.project(values, positions=positions, size=(20, 14), lattice="hex",
                               generator=generator, rule=rule)
    assert np.array_equal(module, image)
