"""The PALACE report page from a drift campaign and a margins.csv (seed 000 Tables 4.1, 5.1, 5.2)."""

import csv
import math

import numpy as np
import pytest

from visnav.analysis import palace_report as pr


def _write(path, rows):
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _drift_rows():
    rows = []
    for surf in ("concrete", "grass"):
        for alt in (6, 30):
            for wind in (0, 90):
                for k, px in enumerate((4.0, 8.0, 30.0 if (surf, alt, wind) == ("grass", 30, 90) else 12.0)):
                    rows.append({"seed": k + 1, "world.wind_from_deg": wind, "status": "ok", "altitude_m": alt,
                                 "surface": surf, "tracker_lost": "False", "drift_m": px * alt / 1073 * 1.15,
                                 "drift_px": px, "mpe_noise_sigma_m": 0.001 * alt, "mean_range_m": alt * 1.15})
    rows.append({**rows[0], "seed": 9, "status": "failed", "drift_px": ""})
    return rows


def _margins_rows():
    base = dict(lateral_pm_deg=40.0, lateral_pm_wc_rps=1.3, lateral_gm_db=10.0, longitudinal_pm_deg=41.0,
                longitudinal_pm_wc_rps=1.0, longitudinal_gm_db=9.0, identified_imu_delay_s=0.09,
                identified_laser_delay_s=-0.01, lateral_gm_wc_rps=3.0, longitudinal_gm_wc_rps=2.2, notes="")
    rows = []
    for alt in (6.0, 18.0):
        rows.append({**base, "altitude_m": alt, "delay_s": "", "compensated": "gps"})
        rows.append({**base, "altitude_m": alt, "delay_s": 0.1, "compensated": False, "lateral_pm_deg": "nan",
                     "notes": "lateral: sweep incomplete"})
        rows.append({**base, "altitude_m": alt, "delay_s": 0.1, "compensated": True, "lateral_pm_deg": 39.0})
    return rows


def test_drift_table_and_the_thesis_aggregates():
    table = pr.drift_table(_drift_rows())
    assert len(table) == 8 and all(r["n"] == 3 for r in table)  # the failed run is left out
    s = pr.drift_summary(table)
    assert s["grass"]["max_px"] == 30.0 and s["concrete"]["max_px"] == 12.0
    assert s["grass"]["mean_of_max_px"] == pytest.approx((3 * 12.0 + 30.0) / 4)
    assert s["concrete"]["mean_px"] == pytest.approx(8.0)


def test_margin_tables_put_the_thesis_beside_ours():
    rows51 = pr.table_5_1_rows(_margins_rows())
    assert rows51[0][:3] == ["6 m", "100 ms", "ours"] and rows51[0][3] == "n/a (sweep lost)"
    assert rows51[1][3] == "39.54 at 2.31"  # Table 5.1, 6 m, 100 ms, lateral PM
    assert rows51[3][3] == "14.72 at 2.17"  # 18 m
    rows52 = pr.table_5_2_rows(_margins_rows())
    assert rows52[2][1].startswith("MPE w/") and rows52[2][-1] == "IMU 90.0 ms, laser -10.0 ms"
    assert rows52[-1][1] == "MPE flight w/43 ms correction" and rows52[-1][2] == "38.50 at 2.78"


def test_the_page_from_a_campaign_directory_and_a_margins_dir(tmp_path):
    camp = tmp_path / "drift"
    camp.mkdir()
    _write(camp / "runs.csv", _drift_rows())
    mdir = tmp_path / "margins"
    mdir.mkdir()
    _write(mdir / "margins.csv", _margins_rows())
    w = np.geomspace(0.3, 14.0, 40)
    frfs = {(6.0, None, "gps", "lateral"): dict(w=w, H=2.0 / (1j * w) ** 2, coherence=np.full(w.size, 0.9))}
    pr.save_frfs(mdir / "frf.npz", frfs)
    back = pr.load_frfs(mdir / "frf.npz")
    assert set(back) == set(frfs) and np.allclose(back[6.0, None, "gps", "lateral"]["H"], 2.0 / (1j * w) ** 2)
    page = pr.write_palace_report(tmp_path / "r.html", [camp], mdir).read_text()
    for text in ("Table 4.1", "Table 5.1", "Table 5.2", "Bode plots at 6 m", "22.812", "MPE flight w/o correction"):
        assert text in page
    assert page.count("<img") == 4  # drift, noise, margins, one Bode
    assert "<h2>Provenance</h2>" in page and "scenario hash" not in page  # a page of campaigns: no one scenario
    with pytest.raises(ValueError, match="nothing to report"):
        pr.write_palace_report(tmp_path / "x.html")
    with pytest.raises(FileNotFoundError, match="no such file"):
        pr.write_palace_report(tmp_path / "x.html", [tmp_path / "missing"])
    assert math.isnan(pr._num(""))
