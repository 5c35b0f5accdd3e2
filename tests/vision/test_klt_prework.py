"""KLT tracking worked out ahead on the render thread (``KltTracker.prework``, issue #19): the same pairs and
feature sets as tracking on delivery, and a result worked out from a state that changed since is not used."""

from __future__ import annotations

import threading

import cv2
import numpy as np

from visnav.vision.klt import KltTracker


def _frames(n: int = 12, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    ground = cv2.GaussianBlur(rng.integers(0, 256, (700, 900)).astype(np.uint8), (0, 0), 2.0)
    return [np.ascontiguousarray(ground[40 + 3 * k:280 + 3 * k, 50 + 4 * k:370 + 4 * k]) for k in range(n)]


def _same(a, b) -> bool:
    return a.n_detected == b.n_detected and np.array_equal(a.prev, b.prev) and np.array_equal(a.curr, b.curr)


def test_prework_gives_the_pairs_of_tracking_on_delivery_and_stale_work_is_redone():
    frames = _frames()
    ref, pre = KltTracker(max_features=40), KltTracker(max_features=40)
    calls = {"main": 0, "worker": 0}
    flow = pre._flow

    def counted(*a):
        calls["main" if threading.current_thread() is threading.main_thread() else "worker"] += 1
        return flow(*a)

    pre._flow = counted
    for k, img in enumerate(frames):
        if k == 6:  # a camera gap restarts both: work prepared before the restart must not be used
            ref.reset()
            work = pre.prework()
            pre.reset()
        else:
            work = pre.prework()
        out = []
        th = threading.Thread(target=lambda: out.append(work(img)))
        th.start()
        th.join()
        a, b = ref.track(img), pre.track(img)
        if k % 2:  # the top-up detection the work handed back runs on the other thread after the delivery, or
            th = threading.Thread(target=out[0])  # (every other frame) by the next track that needs it
            th.start()
            th.join()
        assert _same(a, b), k
        assert np.array_equal(ref.pts, pre.pts) and ref.prev_img is img and pre.prev_img is img
    assert len(ref.pts) >= 20  # features were tracked all along
    assert calls == {"main": 1, "worker": len(frames)}  # the frame after the restart was tracked again on delivery
    # a frame whose image a fault replaced (another array) is tracked on delivery from the tracker's state
    img = frames[-1].copy()
    work = pre.prework()
    th = threading.Thread(target=lambda: work(frames[-1]))
    th.start()
    th.join()
    b, a = pre.track(img), ref.track(img)
    assert _same(a, b) and calls["main"] == 2


def test_render_then_queues_the_follow_up_behind_the_frame_and_not_on_a_closed_pool():
    """``Camera.sample_async``'s worker job: the image, then what ``then`` hands back queued on the same pool
    (run after the frame is handed over); at the end of a run (pool shut down) it is not queued, and no error."""
    from concurrent.futures import ThreadPoolExecutor

    from visnav.sensors.camera import _render_then

    ran = []
    pool = ThreadPoolExecutor(1)
    img = pool.submit(_render_then, lambda p: p * 2, 3, lambda i: (lambda: ran.append(i)), pool).result()
    pool.shutdown(wait=True)
    assert img == 6 and ran == [6]
    assert _render_then(lambda p: p + 1, 1, lambda i: (lambda: ran.append(i)), pool) == 2
    assert ran == [6]
    assert _render_then(lambda p: p + 1, 1, lambda i: None, pool) == 2  # nothing handed back
