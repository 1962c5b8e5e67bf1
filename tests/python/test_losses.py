"""Image objectives through the Python module: SSIM against scikit-image, the
binomial filter against scipy, regularisers against numpy, and image_loss's
gradient against central finite differences."""

import numpy as np
import pytest

skimage_metrics = pytest.importorskip("skimage.metrics")
ndimage = pytest.importorskip("scipy.ndimage")


def sk_ssim(a, b):
    return skimage_metrics.structural_similarity(a, b, channel_axis=2, gaussian_weights=True, sigma=1.5,
                                                 use_sample_covariance=False, data_range=1.0)


def structured_pair(h, w):
    y, x, c = np.meshgrid(np.arange(h), np.arange(w), np.arange(3), indexing="ij")
    a = 0.5 + 0.3 * np.sin(0.4 * x + 0.7 * c) * np.cos(0.3 * y - 0.2 * c)
    a = a + 0.2 * ((x > w // 3) & (y < 2 * h // 3))  # a step edge
    b = a + 0.15 * np.sin(0.9 * x + 1.3 * y + c)
    return a.astype(np.float32), np.clip(b, 0, 1).astype(np.float32)


@pytest.mark.parametrize("shape", [(11, 11), (17, 23), (64, 48), (101, 77)])
def test_ssim_matches_skimage(ptir, shape):
    rng = np.random.default_rng(sum(shape))
    h, w = shape
    pairs = [structured_pair(h, w),
             (rng.random((h, w, 3), dtype=np.float32), rng.random((h, w, 3), dtype=np.float32))]
    a = rng.random((h, w, 3), dtype=np.float32)
    pairs.append((a, np.clip(a + 0.1 * rng.standard_normal((h, w, 3)), 0, 1).astype(np.float32)))
    for a, b in pairs:
        ours = ptir.ssim(a, b)
        assert ours == pytest.approx(sk_ssim(a, b), abs=1e-5)
        # In float64 scikit-image agrees with our double evaluation to rounding.
        assert ours == pytest.approx(sk_ssim(a.astype(np.float64), b.astype(np.float64)), abs=1e-9)
    assert ptir.ssim(a, a) == pytest.approx(1.0, abs=1e-12)


def test_ssim_mask(ptir):
    rng = np.random.default_rng(1)
    a, b = rng.random((30, 30, 3), dtype=np.float32), rng.random((30, 30, 3), dtype=np.float32)
    ones = np.ones((30, 30), np.float32)
    assert ptir.ssim(a, b, ones) == ptir.ssim(a, b)
    # A mask in the alpha channel of an RGBA image, 1 on the left half: the mean of
    # skimage's full SSIM map over the cropped region's left half.
    rgba = np.zeros((30, 30, 4), np.float32)
    rgba[:, :15, 3] = 1.0
    _, smap = skimage_metrics.structural_similarity(a.astype(np.float64), b.astype(np.float64), channel_axis=2,
                                                    gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
                                                    data_range=1.0, full=True)
    expect = smap[5:25, 5:15].mean()
    assert ptir.ssim(a, b, rgba) == pytest.approx(expect, abs=1e-9)
    assert ptir.ssim(a, b, rgba[:, :, 3:4]) == ptir.ssim(a, b, rgba)


def test_binomial_filter_matches_scipy(ptir):
    rng = np.random.default_rng(2)
    img = rng.random((13, 9, 4), dtype=np.float32)
    k = np.outer([1, 2, 1], [1, 2, 1]) / 16.0
    expect = np.stack([ndimage.correlate(img[:, :, c].astype(np.float64), k, mode="nearest") for c in range(4)], -1)
    np.testing.assert_allclose(ptir.binomial_filter(img), expect, atol=1e-6)


def central_differences(f, x, probes, rng, h=1e-3):
    """(index, finite difference) at random entries of the float32 array x."""
    out = []
    for _ in range(probes):
        i = tuple(int(rng.integers(0, n)) for n in x.shape)
        v0 = x[i]
        xp, xm = np.float32(v0 + h), np.float32(v0 - h)
        x[i] = xp
        fp = f(x)
        x[i] = xm
        fm = f(x)
        x[i] = v0
        out.append((i, (fp - fm) / (float(xp) - float(xm))))
    return out


@pytest.mark.parametrize("masked", [False, True])
@pytest.mark.parametrize("binomial", [False, True])
def test_image_loss_gradient(ptir, masked, binomial):
    rng = np.random.default_rng(3 + 2 * masked + binomial)
    h, w = 24, 19
    pred = rng.uniform(0.1, 0.9, (h, w, 3)).astype(np.float32)
    base = ptir.binomial_filter(pred) if binomial else pred
    # Keep the target >= 0.05 away from the (blurred) prediction: no L1 kink within a step.
    sign = np.where(rng.random((h, w, 3)) < 0.5, -1.0, 1.0)
    target = (base + sign * rng.uniform(0.05, 0.25, (h, w, 3))).astype(np.float32)
    mask = rng.random((h, w)).astype(np.float32) if masked else None

    loss, grad = ptir.image_loss(pred, target, mask, lambda_ssim=0.2, binomial=binomial)
    assert grad.shape == (h, w, 3) and grad.dtype == np.float32
    f = lambda p: ptir.image_loss(p, target, mask, lambda_ssim=0.2, binomial=binomial)[0]
    assert f(pred) == loss
    worst = 0.0
    for i, fd in central_differences(f, pred, 40, rng):
        assert grad[i] == pytest.approx(fd, rel=2e-3, abs=1e-8), i
        worst = max(worst, abs(grad[i] - fd) / (abs(fd) + 5e-6))
    print(f"image_loss gradient (masked={masked}, binomial={binomial}): worst relative error {worst:.2e}")


def test_image_loss_value(ptir):
    rng = np.random.default_rng(5)
    pred = rng.random((20, 20, 4), dtype=np.float32)
    target = rng.random((20, 20, 3), dtype=np.float32)
    loss, grad = ptir.image_loss(pred, target, lambda_ssim=0.2, binomial=False)
    l1 = np.abs(pred[:, :, :3].astype(np.float64) - target).mean()
    assert loss == pytest.approx(0.8 * l1 + 0.2 * (1.0 - sk_ssim(pred[:, :, :3], target)), abs=1e-6)
    assert grad.shape == (20, 20, 3)
    blurred = ptir.binomial_filter(pred)
    assert ptir.image_loss(pred, target)[0] == pytest.approx(ptir.image_loss(blurred, target, binomial=False)[0],
                                                              abs=1e-6)


def test_edge_aware_tv_and_prior(ptir):
    rng = np.random.default_rng(6)
    m = rng.random((9, 11, 3), dtype=np.float32)
    guide = rng.random((9, 11, 3), dtype=np.float32)
    md, gd = m.astype(np.float64), guide.astype(np.float64)
    ex = np.exp(-np.abs(gd[:, 1:] - gd[:, :-1]).mean(-1))
    ey = np.exp(-np.abs(gd[1:] - gd[:-1]).mean(-1))
    tv = (((md[:, 1:] - md[:, :-1]) ** 2).sum(-1) * ex).sum() + (((md[1:] - md[:-1]) ** 2).sum(-1) * ey).sum()
    tv /= ex.size + ey.size
    value, d = ptir.edge_aware_tv(m, guide)
    assert value == pytest.approx(tv, rel=1e-9)
    for i, fd in central_differences(lambda x: ptir.edge_aware_tv(x, guide)[0], m, 20, rng):
        assert d[i] == pytest.approx(fd, rel=1e-4, abs=1e-9)

    prior = rng.random((9, 11, 3), dtype=np.float32)
    mask = rng.random((9, 11, 1), dtype=np.float32)
    value, d = ptir.prior_l2(m, prior, mask)
    wd = mask[:, :, 0].astype(np.float64)
    expect = (wd[:, :, None] * (md - prior) ** 2).sum() / (3 * wd.sum())
    assert value == pytest.approx(expect, rel=1e-9)
    np.testing.assert_allclose(d, 2 * wd[:, :, None] * (md - prior) / (3 * wd.sum()), rtol=1e-5, atol=1e-9)


def test_bad_inputs(ptir):
    a = np.zeros((8, 8, 3), np.float32)
    with pytest.raises(ptir.Error):
        ptir.ssim(a, np.zeros((8, 9, 3), np.float32))
    with pytest.raises(ptir.Error):
        ptir.image_loss(a, a, np.zeros((8, 8, 2), np.float32))
