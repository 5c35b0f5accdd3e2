import cv2
import numpy as np
import pytest

from visnav.vision.homography import chi2_threshold, normalized_dlt, ransac_homography, transfer_error

H_TRUE = np.array([[1.02, 0.03, 5.0], [-0.02, 0.98, -3.0], [1e-4, -2e-4, 1.0]])


def _apply(H, x):
    p = np.c_[x, np.ones(len(x))] @ H.T
    return p[:, :2] / p[:, 2:]


def test_dlt_exact_correspondences_recover_h():
    rng = np.random.default_rng(1)
    x1 = rng.uniform(0, 384, (50, 2))
    H = normalized_dlt(x1, _apply(H_TRUE, x1))
    assert np.abs(H - H_TRUE).max() < 1e-9
    # minimal case (4 points)
    H4 = normalized_dlt(x1[:4], _apply(H_TRUE, x1[:4]))
    assert np.abs(H4 - H_TRUE).max() < 1e-9


def test_dlt_rejects_bad_shapes():
    with pytest.raises(ValueError, match="N>=4"):
        normalized_dlt(np.zeros((3, 2)), np.zeros((3, 2)))


def test_chi2_threshold_is_5_99_sigma2():
    assert chi2_threshold(2.0) == pytest.approx(5.991 * 4, rel=1e-3)


def test_ransac_40pct_outliers_matches_opencv():
    rng = np.random.default_rng(7)
    n = 60
    x1 = rng.uniform(0, 384, (n, 2))
    x2 = _apply(H_TRUE, x1) + rng.normal(0, 0.3, (n, 2))
    out = np.zeros(n, bool)
    out[rng.choice(n, int(0.4 * n), replace=False)] = True
    # outliers displaced by 15..40 px in a random direction (clearly beyond the threshold)
    ang = rng.uniform(0, 2 * np.pi, out.sum())
    x2[out] += rng.uniform(15, 40, out.sum())[:, None] * np.c_[np.cos(ang), np.sin(ang)]
    res = ransac_homography(x1, x2, sigma_px=0.5, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(res.inliers, ~out)
    grid = np.stack(np.meshgrid(np.linspace(0, 384, 5), np.linspace(0, 288, 5)), -1).reshape(-1, 2)
    assert np.sqrt(transfer_error(res.H, grid, _apply(H_TRUE, grid))).max() < 0.5
    # adaptive N: with 40% outliers log(0.01)/log(1-0.6^4) = 34 hypotheses suffice (one batch of 64)
    assert res.iterations <= 128
    Hc, mask = cv2.findHomography(x1, x2, cv2.RANSAC, float(np.sqrt(res.threshold_px2)))
    np.testing.assert_array_equal(mask.ravel().astype(bool), res.inliers)
    assert np.sqrt(transfer_error(res.H, grid, _apply(Hc, grid))).max() < 0.3
