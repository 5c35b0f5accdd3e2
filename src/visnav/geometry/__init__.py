"""visnav.geometry: rotations, NED <-> geodetic frames, the pinhole camera, camera mounts."""

from visnav.geometry.camera import (
    BLUEFOX_DIST,
    PinholeCamera,
    ground_sample_distance,
    ray_plane_intersection,
)
from visnav.geometry.frames import LocalTangentPlane
from visnav.geometry.mounts import FixedMount, PanTiltMount, camera_pose_from_mount
from visnav.geometry.rotations import (
    body_rates_to_euler_rates,
    dcm_to_euler,
    euler_rates_to_body_rates,
    euler_to_dcm,
    skew,
    wrap_angle,
)

__all__ = [
    "BLUEFOX_DIST",
    "FixedMount",
    "LocalTangentPlane",
    "PanTiltMount",
    "PinholeCamera",
    "body_rates_to_euler_rates",
    "camera_pose_from_mount",
    "dcm_to_euler",
    "euler_rates_to_body_rates",
    "euler_to_dcm",
    "ground_sample_distance",
    "ray_plane_intersection",
    "skew",
    "wrap_angle",
]
