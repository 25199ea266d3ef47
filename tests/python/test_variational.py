"""The variational rule from Python: rule="variational" with lambda_= and
smoothness=, against a dense numpy solve of (G + lambda R) c = b for order 1
on a periodic frame, a flat image, the report, and the keywords' errors."""

import numpy as np
import pytest

import siproject


def bspline3(t):
    t = np.abs(t)
    return np.where(t < 1, 2 / 3 - t ** 2 + t ** 3 / 2, np.where(t < 2, (2 - t) ** 3 / 6, 0.0))


def bspline2(t):
    t = np.abs(t)
    return np.where(t < 0.5, 0.75 - t ** 2, np.where(t < 1.5, (1.5 - t) ** 2 / 2, 0.0))


def samples(n, W, H, seed):
    g = np.random.default_rng(seed)
    return g.uniform(0, [W, H], size=(n, 2)), g.uniform(-0.3, 0.7, size=n)


def test_flat_image_is_exact_for_any_lambda():
    pos, _ = samples(40, 9, 7, 1)
    values = np.full(40, 0.42)
    for lam in (0.01, 10.0, "gcv", None):
        k = siproject.coefficients(values, positions=pos, size=(9, 7), rule="variational",
                                   lambda_=lam)
        # CG to 1e-9 of ||b|| (the rule's default) on a constant solution.
        np.testing.assert_allclose(k.array, 0.42, atol=1e-6)
        assert k.report["rule"] == "variational"
        if lam in (0.01, 10.0):
            assert k.report["lambda"] == lam


def periodic_axis(x, L):
    """The cubic's periodic basis along one axis: (N, L)."""
    c = np.arange(L) + 0.5
    return sum(bspline3(x[:, None] + L * k - c[None, :]) for k in (-1, 0, 1))


def test_order_one_equals_a_dense_solve():
    W, H, lam = 6, 5, 0.05
    pos, values = samples(60, W, H, 3)
    Phi = (periodic_axis(pos[:, 1], H)[:, :, None] * periodic_axis(pos[:, 0], W)[:, None, :])
    Phi = Phi.reshape(len(values), W * H)
    w = np.full(len(values), W * H / len(values))
    # order 1: A0 (the cubic's autocorrelation, B7) and A1, the autocorrelation
    # of its derivative, by Gauss-Legendre on half-unit cells (exact: the
    # products are piecewise polynomials of degree <= 6)
    a0 = {0: 2416 / 5040, 1: 1191 / 5040, 2: 120 / 5040, 3: 1 / 5040}
    x, wq = np.polynomial.legendre.leggauss(5)
    u = (np.arange(-4, 4)[:, None] * 0.5 + 0.25 * (1 + x[None, :])).ravel()
    wu = np.tile(0.25 * wq, 8)

    def d3(t):
        return bspline2(t + 0.5) - bspline2(t - 0.5)
    a1 = {k: float(np.sum(wu * d3(u) * d3(u - k))) for k in range(4)}

    def circ(a, L):
        M = np.zeros((L, L))
        for n in range(L):
            for k in range(-3, 4):
                M[n, (n + k) % L] += a[abs(k)]
        return M
    R = np.kron(circ(a0, H), circ(a1, W)) + np.kron(circ(a1, H), circ(a0, W))
    G = Phi.T @ (w[:, None] * Phi)
    want = np.linalg.solve(G + lam * R, Phi.T @ (w * values)).reshape(H, W)
    k = siproject.coefficients(values, positions=pos, size=(W, H), rule="variational",
                               lambda_=lam, smoothness=1, boundary="periodic")
    # the stored coefficients are float32
    np.testing.assert_allclose(k.array[:, :, 0], want, atol=1e-6)


@pytest.mark.parametrize("kw, needle", [
    ({"lambda_": -1.0}, "lambda_"),
    ({"lambda_": float("nan")}, "lambda_"),
    ({"lambda_": "big"}, "lambda_"),
    ({"lambda_": True}, "lambda_"),
    ({"smoothness": 3}, "--smoothness 3"),
    ({"lattice": "hex", "generator": "hex-hat"}, "hex-hat"),
    ({"lattice": "hex", "generator": "hex-hat", "smoothness": 2}, "--smoothness 2"),
])
def test_bad_keywords_are_clear_errors(kw, needle):
    pos, values = samples(40, 9, 7, 1)
    with pytest.raises((ValueError, TypeError), match=needle):
        siproject.project(values, positions=pos, size=(9, 7), rule="variational", **kw)


def test_lambda_needs_the_variational_rule():
    pos, values = samples(40, 9, 7, 1)
    with pytest.raises(ValueError, match="--rule variational"):
        siproject.project(values, positions=pos, size=(9, 7), rule="fit", lambda_=0.1)


@pytest.mark.parametrize("generator, order", [("hex-quartic", 2), ("hex-quartic", 1),
                                              ("hex-hat", 1)])
def test_hexagonal_lattice_flat_image_is_exact(generator, order):
    pos, _ = samples(60, 9, 7, 2)
    values = np.full(len(pos), 0.42)
    for lam in (0.01, 10.0, None):
        kw = {} if lam is None else {"lambda_": lam}
        k = siproject.coefficients(values, positions=pos, size=(9, 7), rule="variational",
                                   lattice="hex", generator=generator, smoothness=order, **kw)
        if lam is not None:
            assert k.report["lambda"] == lam
        img = siproject.project(values, positions=pos, size=(9, 7), rule="variational",
                                lattice="hex", generator=generator, smoothness=order, **kw)
        # CG to 1e-9 of ||b|| on a constant solution, the image float32
        # (0.42 to 3e-8): 1e-6 bounds both with a margin
        assert np.allclose(img, 0.42, atol=1e-6)
