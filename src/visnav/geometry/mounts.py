"""Camera mounts: camera pose in the world from the vehicle pose.

Frames: world NED, body FRD, camera OpenCV (x right, y down, z optical axis).
``R_cam_to_body`` (C_c^b) maps camera-frame vectors to body; ``C_bn`` (C_b^n, seed 002
eq. 3.2) maps body to NED; so ``C_cn = C_bn @ R_cam_to_body`` maps camera to NED.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["FixedMount", "PanTiltMount", "camera_pose_from_mount"]


def _vec3(x, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be a finite vector of shape (3,), got {x!r}")
    return a


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def camera_pose_from_mount(
    R_cam_to_body: np.ndarray, lever_arm: np.ndarray, position_ned, C_bn
) -> tuple[np.ndarray, np.ndarray]:
    """(camera centre in NED, C_cn) for a vehicle at ``position_ned`` with attitude ``C_bn``.

    Broadcasts over leading axes: ``position_ned`` (..., 3), ``C_bn`` (..., 3, 3).
    """
    p = np.asarray(position_ned, dtype=float)
    C = np.asarray(C_bn, dtype=float)
    if p.ndim < 1 or p.shape[-1] != 3:
        raise ValueError(f"position_ned must have shape (..., 3), got shape {p.shape}")
    if C.ndim < 2 or C.shape[-2:] != (3, 3):
        raise ValueError(f"C_bn must have shape (..., 3, 3), got shape {C.shape}")
    cam_pos = p + C @ lever_arm
    return cam_pos, C @ R_cam_to_body


def _world_to_camera(points_ned, cam_pos: np.ndarray, C_cn: np.ndarray) -> np.ndarray:
    pts = np.asarray(points_ned, dtype=float)
    if pts.ndim < 1 or pts.shape[-1] != 3:
        raise ValueError(f"points_ned must have shape (N, 3), got shape {pts.shape}")
    if cam_pos.shape != (3,):
        raise ValueError(f"world_to_camera takes one vehicle pose, got position shape {cam_pos.shape}")
    # Row-wise C_nc (p - c) = C_cn^T (p - c).
    return (pts - cam_pos) @ C_cn


@dataclass(frozen=True, eq=False)
class FixedMount:
    """Camera rigidly attached to the body: orientation ``R_cam_to_body`` and centre ``lever_arm``.

    ``lever_arm`` is the camera centre in body FRD [m] relative to the vehicle reference point.
    """

    R_cam_to_body: np.ndarray
    lever_arm: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        R = np.asarray(self.R_cam_to_body, dtype=float)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)):
            raise ValueError(f"R_cam_to_body must be a finite 3x3 matrix, got {self.R_cam_to_body!r}")
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) <= 0:
            raise ValueError(f"R_cam_to_body must be a rotation matrix (orthonormal, det +1), got {R}")
        object.__setattr__(self, "R_cam_to_body", _readonly(R))
        object.__setattr__(self, "lever_arm", _readonly(_vec3(self.lever_arm, "lever_arm")))

    @classmethod
    def depressed(cls, depression_deg: float, lever_arm=(0.0, 0.0, 0.0)) -> FixedMount:
        """Forward camera looking ``depression_deg`` below the body x axis (60 deg for PALACE).

        Optical axis z_cam = (cos d, 0, sin d) in the body x-z plane, x_cam = body y (right),
        y_cam = z_cam x x_cam (image down; = body z at d = 0, body -x at d = 90 deg).
        """
        d = float(depression_deg)
        if not (np.isfinite(d) and -180.0 <= d <= 180.0):
            raise ValueError(f"depression_deg must be in [-180, 180], got {depression_deg!r}")
        d = np.radians(d)
        z_cam = np.array([np.cos(d), 0.0, np.sin(d)])
        x_cam = np.array([0.0, 1.0, 0.0])
        y_cam = np.cross(z_cam, x_cam)
        return cls(np.column_stack([x_cam, y_cam, z_cam]), np.asarray(lever_arm, dtype=float))

    def camera_pose(self, position_ned, C_bn) -> tuple[np.ndarray, np.ndarray]:
        """(camera centre in NED (3,), C_cn (3, 3) camera -> NED) from the vehicle pose."""
        return camera_pose_from_mount(self.R_cam_to_body, self.lever_arm, position_ned, C_bn)

    def world_to_camera(self, points_ned, position_ned, C_bn) -> np.ndarray:
        """NED points (N, 3) expressed in the camera frame (N, 3)."""
        cam_pos, C_cn = self.camera_pose(position_ned, C_bn)
        return _world_to_camera(points_ned, cam_pos, C_cn)


class PanTiltMount:
    """Two-axis gimbal: ``pan`` about body z, then ``tilt`` (depression) about the panned y axis.

    At pan = 0 the camera points like :meth:`FixedMount.depressed` with depression = tilt.
    Angles in rad; assigning ``pan`` / ``tilt`` or calling :meth:`set` clamps to the limits.
    """

    def __init__(
        self,
        pan: float = 0.0,
        tilt: float = 0.0,
        pan_limits: tuple[float, float] = (-np.pi, np.pi),
        tilt_limits: tuple[float, float] = (0.0, np.pi / 2),
        lever_arm=(0.0, 0.0, 0.0),
    ) -> None:
        self.pan_limits = self._limits(pan_limits, "pan_limits")
        self.tilt_limits = self._limits(tilt_limits, "tilt_limits")
        self.lever_arm = _readonly(_vec3(lever_arm, "lever_arm"))
        self._pan = 0.0
        self._tilt = 0.0
        self.set(pan, tilt)

    @staticmethod
    def _limits(lim, name: str) -> tuple[float, float]:
        try:
            lo, hi = (float(v) for v in lim)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a pair (low, high) [rad], got {lim!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
            raise ValueError(f"{name} must be finite with low <= high, got {lim!r}")
        return lo, hi

    @staticmethod
    def _clamp(value: float, lim: tuple[float, float], name: str) -> float:
        v = float(value)
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite [rad], got {value!r}")
        return min(max(v, lim[0]), lim[1])

    @property
    def pan(self) -> float:
        return self._pan

    @pan.setter
    def pan(self, value: float) -> None:
        self._pan = self._clamp(value, self.pan_limits, "pan")

    @property
    def tilt(self) -> float:
        return self._tilt

    @tilt.setter
    def tilt(self, value: float) -> None:
        self._tilt = self._clamp(value, self.tilt_limits, "tilt")

    def set(self, pan: float, tilt: float) -> None:
        """Command both axes; each is clamped to its limits."""
        self.pan = pan
        self.tilt = tilt

    @property
    def R_cam_to_body(self) -> np.ndarray:
        """C_c^b = Rz(pan) Ry(-tilt) R0, R0 the camera at zero pan and tilt (optical axis = body x)."""
        cp, sp = np.cos(self._pan), np.sin(self._pan)
        ct, st = np.cos(self._tilt), np.sin(self._tilt)
        Rz = np.array([[cp, -sp, 0.0], [sp, cp, 0.0], [0.0, 0.0, 1.0]])
        Ry_down = np.array([[ct, 0.0, -st], [0.0, 1.0, 0.0], [st, 0.0, ct]])  # Ry(-tilt)
        R0 = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        return Rz @ Ry_down @ R0

    def camera_pose(self, position_ned, C_bn) -> tuple[np.ndarray, np.ndarray]:
        """(camera centre in NED (3,), C_cn (3, 3) camera -> NED) from the vehicle pose."""
        return camera_pose_from_mount(self.R_cam_to_body, self.lever_arm, position_ned, C_bn)

    def world_to_camera(self, points_ned, position_ned, C_bn) -> np.ndarray:
        """NED points (N, 3) expressed in the camera frame (N, 3)."""
        cam_pos, C_cn = self.camera_pose(position_ned, C_bn)
        return _world_to_camera(points_ned, cam_pos, C_cn)

    def __repr__(self) -> str:
        return (
            f"PanTiltMount(pan={self._pan!r}, tilt={self._tilt!r}, pan_limits={self.pan_limits!r}, "
            f"tilt_limits={self.tilt_limits!r}, lever_arm={self.lever_arm.tolist()!r})"
        )
