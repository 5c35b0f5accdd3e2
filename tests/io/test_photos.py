"""A folder of geotagged photos as a recording (io/photos.py): EXIF written here with Pillow, and the real
Seneca survey (../shared/data/survey_seneca) when present."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.shared_data import missing_reason, shared_data_dir

PIL = pytest.importorskip("PIL")
from PIL import Image  # noqa: E402
from PIL.ExifTags import IFD  # noqa: E402

from visnav.io.logs import open_recording  # noqa: E402
from visnav.io.photos import PhotoRecording, read_exif, read_photos  # noqa: E402
from visnav.io.recording import RecordingError  # noqa: E402

WGS84_A, WGS84_E2 = 6378137.0, 6.69437999014e-3


def _dms(deg: float):
    deg = abs(deg)
    d = int(deg)
    m = int((deg - d) * 60)
    return (float(d), float(m), (deg - d - m / 60) * 3600)


def _photo(path, size=(40, 30), time="2013:06:04 13:37:29", subsec=None, lat=41.0, lon=-83.3, alt=280.0,
           orientation=1, exif_extra=None, xmp=None, seed=0):
    rng = np.random.default_rng(seed)
    im = Image.fromarray((rng.random((size[1], size[0])) * 255).astype(np.uint8))
    ex = Image.Exif()
    ex[274] = orientation
    e = {36867: time} if time else {}
    if subsec:
        e[37521] = subsec
    e |= exif_extra or {}
    ex[IFD.Exif] = e
    if lat is not None:
        ex[IFD.GPSInfo] = {1: "N" if lat >= 0 else "S", 2: _dms(lat), 3: "E" if lon >= 0 else "W", 4: _dms(lon),
                           5: b"\x01" if alt < 0 else b"\x00", 6: abs(alt)}
    im.save(path, exif=ex, **({"xmp": xmp} if xmp else {}))


def _meridian_radius(lat_deg):  # closed form (the radius of curvature of the meridian)
    s = math.sin(math.radians(lat_deg))
    return WGS84_A * (1 - WGS84_E2) / (1 - WGS84_E2 * s * s) ** 1.5


def _normal_radius(lat_deg):
    s = math.sin(math.radians(lat_deg))
    return WGS84_A / math.sqrt(1 - WGS84_E2 * s * s)


def test_gps_time_and_focal_from_exif(tmp_path):
    f35 = {41989: 28}
    _photo(tmp_path / "b.jpg", time="2013:06:04 13:37:35", subsec="5", lat=41.0001, lon=-83.2998, alt=283.0,
           exif_extra=f35, seed=1)
    _photo(tmp_path / "a.jpg", time="2013:06:04 13:37:29", lat=41.0, lon=-83.3, alt=280.0, exif_extra=f35)
    _photo(tmp_path / "c.jpg", time="2013:06:04 13:37:40", lat=-0.5, lon=10.0, alt=-12.5, exif_extra=f35, seed=2)
    rec = open_recording(tmp_path)
    assert isinstance(rec, PhotoRecording)
    fr, g = rec.streams["frames"], rec.streams["gps"]
    assert list(fr["file"]) == ["a.jpg", "b.jpg", "c.jpg"]  # ordered by time
    np.testing.assert_allclose(fr["t_s"], [0.0, 6.5, 11.0])  # SubSecTimeOriginal "5" = 0.5 s
    # NED about the first fix: north / east by the radii of curvature (closed form), altitude up
    n = math.radians(1e-4) * _meridian_radius(41.00005)
    e = math.radians(2e-4) * _normal_radius(41.0) * math.cos(math.radians(41.0))
    assert g["n_m"][1] == pytest.approx(n, abs=0.05) and g["e_m"][1] == pytest.approx(e, abs=0.05)
    assert g["d_m"][1] == pytest.approx(-3.0, abs=0.01)
    assert read_exif(tmp_path / "c.jpg").lat_deg == pytest.approx(-0.5) and read_exif(tmp_path / "c.jpg").alt_m == -12.5
    # 35 mm equivalent over the 43.27 mm diagonal of the 35 mm frame
    assert rec.camera.camera.fx == pytest.approx(28 / math.hypot(36, 24) * math.hypot(40, 30))
    assert rec.camera.mount.R_cam_to_body @ np.array([0, 0, 1.0]) == pytest.approx([0, 0, 1])  # nadir
    assert any("no camera.yaml" in s for s in rec.notes)
    img, why = rec.image(0)
    assert why is None and img.shape == (30, 40) and img.dtype == np.uint8


def test_focal_plane_resolution_scaled_by_the_stored_width(tmp_path):
    # 4.3 mm x 16393.44 px/inch on a 4000 px sensor, photo stored at 40 px wide: fx = 4.3 / 25.4 * 16393.44 / 100
    _photo(tmp_path / "p.jpg", exif_extra={37386: 4.3, 41486: 16393.44, 41488: 2, 40962: 4000})
    rec = read_photos(tmp_path)
    assert rec.camera.camera.fx == pytest.approx(4.3 / 25.4 * 16393.44 * 40 / 4000, rel=1e-6)


def test_orientation_scaling_other_aspect_and_missing_time(tmp_path):
    (tmp_path / "images").mkdir()
    d = tmp_path / "images"
    _photo(d / "1.jpg", size=(80, 60), time="2020:01:01 00:00:00", exif_extra={41989: 28})  # twice the size
    _photo(d / "2.jpg", size=(40, 30), time="2020:01:01 00:00:05", seed=1)
    _photo(d / "3.jpg", size=(30, 40), time="2020:01:01 00:00:09", seed=2)  # another aspect ratio
    _photo(d / "4.jpg", size=(30, 40), time="2020:01:01 00:00:12", orientation=6, seed=3)  # rotated: 40 wide
    _photo(d / "5.jpg", time=None, seed=4)
    (tmp_path / "camera.yaml").write_text("image_size: [40, 30]\nintrinsics: {fx: 50, fy: 50, cx: 19.5, cy: 14.5}\n")
    rec = open_recording(tmp_path)
    assert rec.camera.camera.fx == 50 and rec.camera.mount is not None  # camera.yaml wins; nadir by default
    assert list(rec.streams["frames"]["file"]) == ["images/1.jpg", "images/2.jpg", "images/3.jpg", "images/4.jpg"]
    assert any("5.jpg: no time" in s for s in rec.notes)
    big, why = rec.image(0)
    assert why is None and big.shape == (30, 40)
    src = np.asarray(Image.open(d / "1.jpg").convert("L"), float)  # the 2x2 block means of the stored photo
    np.testing.assert_allclose(big, src.reshape(30, 2, 40, 2).mean(axis=(1, 3)), atol=2.0)
    assert rec.image(2)[0] is None and "another aspect ratio" in rec.image(2)[1]
    rot, why = rec.image(3)
    assert why is None and rot.shape == (30, 40)
    assert rec.sample("frames", 2) is None and rec.skipped["frames"] == 1


def test_dji_xmp_gimbal_and_flight_angles(tmp_path):
    xmp = (b'<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF><rdf:Description drone-dji:GimbalRollDegree="+0.50" '
           b'drone-dji:GimbalPitchDegree="-89.90" drone-dji:GimbalYawDegree="+12.3" drone-dji:FlightRollDegree="+1.5" '
           b'drone-dji:FlightPitchDegree="-2.0"><drone-dji:FlightYawDegree>+30.0</drone-dji:FlightYawDegree>'
           b'</rdf:Description></rdf:RDF></x:xmpmeta>')
    _photo(tmp_path / "d.jpg", xmp=xmp, exif_extra={41989: 24})
    rec = read_photos(tmp_path)
    np.testing.assert_allclose(np.degrees(rec.streams["camera_attitude"]["tilt_rad"]), [89.9])
    np.testing.assert_allclose(np.degrees(rec.streams["camera_attitude"]["roll_rad"]), [0.5])
    att = rec.streams["attitude"]
    np.testing.assert_allclose(np.degrees([att["roll_rad"][0], att["pitch_rad"][0], att["yaw_rad"][0]]),
                               [1.5, -2.0, 30.0])


def test_bad_folders_one_line(tmp_path):
    with pytest.raises(RecordingError, match="no sensor CSV|no photos"):
        open_recording(tmp_path)
    _photo(tmp_path / "x.jpg", exif_extra={})  # no focal length, no camera.yaml
    with pytest.raises(RecordingError, match="no focal length"):
        read_photos(tmp_path)
    (tmp_path / "y.jpg").write_bytes(b"not a jpeg")
    _photo(tmp_path / "x.jpg", exif_extra={41989: 24})
    rec = read_photos(tmp_path)
    assert any("y.jpg: cannot read the photo" in s for s in rec.notes) and rec.count("frames") == 1


def test_seneca_survey_folder():
    d = shared_data_dir() / "survey_seneca"
    if not d.is_dir():
        pytest.skip(missing_reason(d))
    rec = open_recording(d)
    assert rec.count("frames") == 80 and rec.count("gps") == 80
    g = rec.streams["gps"]
    t = g["t_s"]
    assert t[0] == 0 and 500 < t[-1] < 700 and np.all(np.diff(t) > 0)
    step = np.hypot(np.diff(g["n_m"]), np.diff(g["e_m"])) / np.diff(t)
    assert 3.0 < np.median(step) < 9.0  # a survey speed (README: ~4-5 m/s; EXIF times are whole seconds)
    assert rec.camera.camera.fx == pytest.approx(832.6)
    img, why = rec.image(0)
    assert why is None and img.shape == (900, 1200)
