"""Pad detection and pose (vision/ellipses.py, vision/pad.py) against closed forms, cv2.solvePnP and
rendered frames (sensors/pad_camera.py on world/pad.py)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.pad import PadLayout
from visnav.sensors.pad_camera import PadSceneRenderer
from visnav.vision.ellipses import Ring, concentric_centre, ellipse_from_conic, line_conic_intersections
from visnav.vision.homography import normalized_dlt
from visnav.vision.pad import PadDetector, pose_from_homography, refine_pose, rotvec_to_dcm
from visnav.world.maps import GeoImage
from visnav.world.pad import RING_GREY, _draw_ring, pad_board
from visnav.world.scene import World
from visnav.world.textures import landing_field
from visnav.world.wind import SteadyWind, Wind

LAYOUT = PadLayout()
CAM = PinholeCamera.ideal(640, 480, 640.0)
K = CAM.K


def look_at(pos, target=np.zeros(3)) -> np.ndarray:
    """C_cn of a camera at ``pos`` looking at ``target`` (image x towards east where possible)."""
    z = np.asarray(target, float) - pos
    z /= np.linalg.norm(z)
    x = np.array([0.0, 1.0, 0.0]) - z * z[1]
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def circle_image(R, t, centre, r) -> np.ndarray:
    """Exact image conic of the pad-plane circle (centre (2,), radius r) for x ~ K (R X + t)."""
    H = K @ np.column_stack([R[:, 0], R[:, 1], t])
    a, b = centre
    C = np.array([[1.0, 0.0, -a], [0.0, 1.0, -b], [-a, -b, a * a + b * b - r * r]])
    Hi = np.linalg.inv(H)
    Q = Hi.T @ C @ Hi
    return Q / np.linalg.norm(Q)


def exact_rings(R, t, cfg) -> list[Ring]:
    out = []
    for c in cfg.centres:
        Qo, Qi = circle_image(R, t, c, cfg.r_outer), circle_image(R, t, c, cfg.r_inner)
        m, r2 = concentric_centre(Qo, Qi)
        eo, ei = ellipse_from_conic(Qo), ellipse_from_conic(Qi)
        out.append(Ring(eo, ei, Qo, Qi, m, float(np.sqrt(r2)), float(np.sqrt(eo[2] * eo[3]))))
    return out


def camera_rt(pos, C_cn):
    R = C_cn.T
    return R, -R @ pos


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(3)
    board = pad_board(LAYOUT, 0.002, rng)
    ground = landing_field("asphalt", 40.0, 0.02, rng=rng)
    world = World(ground=ground, surface="asphalt", wind=Wind(SteadyWind(0.0, 0.0), None))
    return board, world, rng


def render(board, world, pos, C_cn, rng, noise=2.0):
    img = PadSceneRenderer(CAM, board, rng).render(pos, C_cn, world)
    return cv2.add(img, rng.normal(0.0, noise, img.shape).round().astype(np.int16), dtype=cv2.CV_8U)


# ---------------------------------------------------------------------------------- conic algebra
def test_concentric_centre_is_the_projected_centre_not_the_ellipse_centre():
    pos = np.array([6.0, -4.0, -8.0])
    R, t = camera_rt(pos, look_at(pos))
    cfg = LAYOUT.configurations()[0]
    c = cfg.centres[1]
    Qo, Qi = circle_image(R, t, c, cfg.r_outer), circle_image(R, t, c, cfg.r_inner)
    m, r2 = concentric_centre(Qo, Qi)
    p = K @ (R @ np.r_[c, 0.0] + t)
    assert np.allclose(m, p[:2] / p[2], atol=1e-9)
    assert r2 == pytest.approx((cfg.r_inner / cfg.r_outer) ** 2, rel=1e-9)
    # the perspective bias the method removes: the ellipse centre is off by a visible amount
    assert np.hypot(*(np.array(ellipse_from_conic(Qo)[:2]) - m)) > 0.05


def test_line_conic_intersections_on_a_circle():
    Q = np.diag([1.0, 1.0, -4.0])  # x^2 + y^2 = 4
    pts = line_conic_intersections(np.array([0.0, 0.0]), np.array([1.0, 1.0]), Q)
    assert np.allclose(pts, [[-np.sqrt(2), -np.sqrt(2)], [np.sqrt(2), np.sqrt(2)]])
    assert np.all(np.isnan(line_conic_intersections(np.array([5.0, 5.0]), np.array([6.0, 5.0]), Q)))


# ---------------------------------------------------------------------------------- pose
@pytest.mark.parametrize("pos", [[0.5, 0.3, -20.0], [4.0, -3.0, -10.0], [0.2, 0.1, -3.0], [-0.1, 0.05, -1.0]])
@pytest.mark.parametrize("k", [0, 3])
def test_pose_from_exact_ellipses_is_exact(pos, k):
    pos = np.asarray(pos, float)
    C = look_at(pos, np.array([0.05, -0.02, 0.0]))
    R, t = camera_rt(pos, C)
    det = PadDetector(LAYOUT, K)
    pose = det.pose_from_rings(exact_rings(R, t, LAYOUT.configurations()[k]), k)
    assert np.linalg.norm(pose.position - pos) < 1e-6
    assert np.allclose(pose.C_cn, C, atol=1e-8)


def test_mirrored_ordering_is_rejected():
    pos = np.array([1.0, 2.0, -6.0])
    R, t = camera_rt(pos, look_at(pos))
    det = PadDetector(LAYOUT, K)
    rings = exact_rings(R, t, LAYOUT.configurations()[1])
    X, keys = det._plane[1]
    uv = det.image_points(rings, keys, (0, 2, 1))  # B and C swapped: the mirror image of the pad
    H = normalized_dlt(X[:, :2], uv)
    assert pose_from_homography(H, K) is None  # it fits, but with the camera below the plane


def test_pose_equals_solvepnp_on_the_same_points():
    rng = np.random.default_rng(7)
    det = PadDetector(LAYOUT, K)
    for pos in ([0.4, -0.3, -15.0], [2.0, 1.0, -5.0]):
        pos = np.asarray(pos, float)
        R, t = camera_rt(pos, look_at(pos, np.array([0.1, 0.2, 0.0])))
        X, keys = det._plane[0]
        uv = det.image_points(exact_rings(R, t, LAYOUT.configurations()[0]), keys, (0, 1, 2))
        uv = uv + rng.normal(0.0, 0.3, uv.shape)
        R0, t0 = pose_from_homography(normalized_dlt(X[:, :2], uv), K)
        Rg, tg, _, _ = refine_pose(R0, t0, X, uv, K)
        ok, rvec, tvec = cv2.solvePnP(X, uv, K, None, flags=cv2.SOLVEPNP_ITERATIVE)
        assert ok
        c_cv = -cv2.Rodrigues(rvec)[0].T @ tvec.ravel()
        assert np.linalg.norm(-Rg.T @ tg - c_cv) < 1e-4  # solvePnP stops at its own tolerance
        # both at the same least-squares minimum once OpenCV iterates to convergence
        crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 200, 1e-15)
        rvec, tvec = cv2.solvePnPRefineLM(X, uv, K, None, rvec, tvec, crit)
        Rc = cv2.Rodrigues(rvec)[0]
        assert np.linalg.norm(-Rg.T @ tg + Rc.T @ tvec.ravel()) < 1e-6
        assert np.allclose(Rg, Rc, atol=1e-8)


def test_rotvec_to_dcm_matches_rodrigues():
    w = np.array([0.3, -0.2, 0.5])
    assert np.allclose(rotvec_to_dcm(w), cv2.Rodrigues(w)[0], atol=1e-12)


# ---------------------------------------------------------------------------------- rendered frames
def expected_rings(pos, C_cn, margin=4.0, min_radius=8.0):
    """Image centres of every ring fully in the image and at least ``min_radius`` px in radius (below
    that the renderer's anti-aliasing blur closes the ring's hole: docs/pad.md)."""
    R, t = camera_rt(pos, C_cn)
    out = []
    for cfg in LAYOUT.configurations():
        for c in cfg.centres:
            ang = np.linspace(0, 2 * np.pi, 64, endpoint=False)
            P = np.column_stack([c[0] + cfg.r_outer * np.cos(ang), c[1] + cfg.r_outer * np.sin(ang), np.zeros(64)])
            uv = CAM.project(P @ R.T + t)
            full = np.all((uv > margin) & (uv < [640 - 1 - margin, 480 - 1 - margin]))
            if full and 0.5 * np.ptp(uv, axis=0).min() >= min_radius:
                p = K @ (R @ np.r_[c, 0.0] + t)
                out.append(p[:2] / p[2])
    return np.array(out)


@pytest.mark.parametrize("h", [20.0, 10.0, 3.0, 1.0])
def test_detection_finds_every_circle(scene, h):
    """At R-MAX heights h (skids; the camera is 0.4 m higher, as in the pad-landing scenario)."""
    board, world, rng = scene
    pos = np.array([0.15 * h, -0.1 * h, -h - 0.4])
    C = look_at(pos, np.array([0.02, 0.01, 0.0]))
    img = render(board, world, pos, C, rng)
    d = PadDetector(LAYOUT, K).detect(img)
    exp = expected_rings(pos, C)
    assert len(exp) >= 3
    got = np.array([r.centre for r in d.rings])
    dist = np.linalg.norm(exp[:, None, :] - got[None, :, :], axis=2).min(axis=1)
    assert np.all(dist < 0.5), dist
    assert d.pose is not None
    complete = [k for k, cfg in enumerate(LAYOUT.configurations())
                if len(expected_rings(pos, C)) and _complete(pos, C, cfg)]
    assert d.pose.config == min(complete)
    err = np.linalg.norm(d.pose.position - pos)
    sig = np.sqrt(np.trace(d.pose.cov))
    assert err < 0.002 * -pos[2] + 0.002
    assert err < 4.0 * sig


def _complete(pos, C, cfg):
    R, t = camera_rt(pos, C)
    ang = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    for c in cfg.centres:
        P = np.column_stack([c[0] + cfg.r_outer * np.cos(ang), c[1] + cfg.r_outer * np.sin(ang), np.zeros(64)])
        uv = CAM.project(P @ R.T + t)
        if not np.all((uv > 4) & (uv < [635, 475])) or 0.5 * np.ptp(uv, axis=0).min() < 8:
            return False
    return True


def test_covariance_grows_with_range(scene):
    board, world, rng = scene
    det = PadDetector(LAYOUT, K)
    sig = []
    for h in (1.2, 4.0, 12.0, 20.0):
        pos = np.array([0.05, 0.02, -h])
        d = det.detect(render(board, world, pos, look_at(pos), rng))
        sig.append(np.sqrt(np.trace(d.pose.cov)))
    assert np.all(np.diff(sig) > 0)
    assert sig[-1] > 20 * sig[0]


def test_no_pose_without_the_pattern(scene):
    board, world, rng = scene
    pos = np.array([15.0, 12.0, -10.0])  # looking straight down at bare asphalt
    img = render(board, world, pos, look_at(pos, pos * [1, 1, 0]), rng)
    assert PadDetector(LAYOUT, K).detect(img).pose is None


def test_no_pose_with_half_the_pattern(scene):
    board, world, rng = scene
    det = PadDetector(LAYOUT, K)
    pos = np.array([0.3, 0.2, -10.0])
    C = look_at(pos)
    R, t = camera_rt(pos, C)
    img = render(board, world, pos, C, rng)
    assert det.detect(img).pose is not None
    # cut along the hypotenuse B-C of every configuration (through the pad centre); keep the A side
    p0, p1 = (K @ (R @ np.array([s, -s, 0.0]) + t) for s in (-1.0, 1.0))
    p0, p1 = p0[:2] / p0[2], p1[:2] / p1[2]
    u, v = np.meshgrid(np.arange(640), np.arange(480))
    side = (p1[0] - p0[0]) * (v - p0[1]) - (p1[1] - p0[1]) * (u - p0[0])
    pa = K @ (R @ np.array([-1.0, -1.0, 0.0]) + t)
    sa = np.sign((p1[0] - p0[0]) * (pa[1] / pa[2] - p0[1]) - (p1[1] - p0[1]) * (pa[0] / pa[2] - p0[0]))
    cut = img.copy()
    cut[np.sign(side) != sa] = 128
    d = det.detect(cut)
    assert d.pose is None, (d.pose.config, d.pose.position)


@pytest.mark.parametrize("where", ["mirror", "aside"])
def test_extra_ring_gives_no_false_pose(scene, where):
    _, world, rng = scene
    cfg = LAYOUT.configurations()[0]
    board = pad_board(LAYOUT, 0.002, np.random.default_rng(3))
    img = board.image.astype(np.float32)
    # "mirror": A reflected across the hypotenuse, which with B and C makes a second, equally valid
    # configuration 0 around the same centre; "aside": the same ring off the pattern
    c = np.array([cfg.leg_m / 2, cfg.leg_m / 2]) if where == "mirror" else np.array([2.6, 0.4])
    _draw_ring(img, board.north0, board.east0, board.resolution_m, c[0], c[1], cfg.r_outer, cfg.r_inner)
    assert img.min() <= RING_GREY + 1
    decoy = GeoImage(np.rint(img).astype(np.uint8), board.north0, board.east0, board.resolution_m)
    pos = np.array([0.2, 0.3, -16.0])
    d = PadDetector(LAYOUT, K).detect(render(decoy, world, pos, look_at(pos), rng))
    if d.pose is not None:  # a true pose, within its own covariance (a smaller configuration is coarser)
        err = np.linalg.norm(d.pose.position - pos)
        assert err < 0.01 * 16.0 and err < 4.0 * np.sqrt(np.trace(d.pose.cov))
        if where == "mirror":
            assert d.pose.config != 0  # the ambiguous configuration is never used


def test_detection_under_shadow_and_dim_light(scene):
    """A shadow edge across the pad (board at 45 % in it) and the frame at 55 % brightness."""
    _, world, rng = scene
    board = pad_board(LAYOUT, 0.002, np.random.default_rng(3), shadow=(30.0, 0.3, 0.45))
    det = PadDetector(LAYOUT, K)
    for h in (12.0, 3.0):
        pos = np.array([0.1 * h, 0.05 * h, -h])
        img = PadSceneRenderer(CAM, board, rng).render(pos, look_at(pos), world)
        img = cv2.convertScaleAbs(img, alpha=0.55)
        img = cv2.add(img, rng.normal(0.0, 2.0, img.shape).round().astype(np.int16), dtype=cv2.CV_8U)
        d = det.detect(img)
        assert d.pose is not None, d.reason
        err = np.linalg.norm(d.pose.position - pos)
        assert err < 0.01 * h and err < 4.0 * np.sqrt(np.trace(d.pose.cov))
