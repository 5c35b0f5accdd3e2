"""CONDOR gimbal camera (seed 004 §2.1.1): 3-axis stabilised gimbal, camera AHRS, pan potentiometer.

The camera body frame has x along the optical axis, y right, z down; its attitude in NED is the
Z-Y-X Euler triple (roll, tilt, pan) with the tilt negative below the horizon and the roll about
the optical axis, so that a camera roll is exactly a 2-D rotation of the image (seed 004 eq. 3.9-3.10).
"""

from __future__ import annotations

import numpy as np

from visnav.geometry.rotations import euler_to_dcm

#: OpenCV camera axes (x right, y down, z optical axis) from camera-body axes (x fwd, y right, z down)
C_CV_CB = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])


def camera_dcm(pan: float, tilt: float, roll: float) -> np.ndarray:
    """``C_n^cv``: NED -> OpenCV camera frame for a camera at (pan, tilt, roll) [rad] in NED."""
    return C_CV_CB @ euler_to_dcm(np.array([roll, tilt, pan])).T


def project_points(camera, cam_pos_ned, pan: float, tilt: float, roll: float, points_ned) -> np.ndarray:
    """Pixels (N, 2) of NED points seen by ``camera`` (a PinholeCamera) at the given pose."""
    p = (np.asarray(points_ned, float) - np.asarray(cam_pos_ned, float)) @ camera_dcm(pan, tilt, roll).T
    return camera.project(p)


def centred_coords(camera, uv) -> tuple[np.ndarray, np.ndarray]:
    """Seed 004 image coordinates (X right, Y up) [px] from the image centre of OpenCV pixels."""
    uv = np.asarray(uv, float)
    return uv[..., 0] - (camera.width - 1) / 2.0, (camera.height - 1) / 2.0 - uv[..., 1]
