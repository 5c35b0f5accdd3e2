"""``same_image`` on full-size frames, where it compares the centre band first: the answer stays
``np.array_equal``'s for one changed byte anywhere (first, band edges, middle, last) and for copies."""

import numpy as np

from visnav.navigation.base import same_image


def test_full_frame_band_first_is_array_equal():
    rng = np.random.default_rng(11)
    img = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
    assert same_image(img, img.copy())
    n = img.size
    w = n // 8  # bytes per word: 8; the band is words [7/16, 9/16) of the frame
    for k in (0, 1, n * 7 // 16 - 1, n * 7 // 16, n // 2, n * 9 // 16 - 1, n * 9 // 16, n - 1, w):
        b = img.copy().reshape(-1)
        b[k] ^= 0x10
        b = b.reshape(img.shape)
        assert same_image(img, b) is False and not np.array_equal(img, b)
    assert same_image(np.zeros((480, 640), np.uint8), np.zeros((480, 640), np.uint8))
