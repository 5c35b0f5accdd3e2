"""Report figures as a reader sees them: mode legend, visible legend entries, errors on their own axes,
legends off the data, no colliding labels, and the CONDOR bank limit cycle measured and stated."""

import math
from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402

from visnav.analysis import report  # noqa: E402
from visnav.scenarios.schema import load_scenario  # noqa: E402
from visnav.flightlog import FlightLog  # noqa: E402
from visnav.app.missions import make_simulation  # noqa: E402


@pytest.fixture
def figures(monkeypatch):
    """The matplotlib figures a report module makes, kept open instead of encoded."""
    made = []

    def keep(fig):
        made.append(fig)
        return f"fig{len(made) - 1}"

    import sys

    import visnav.analysis.condor_report, visnav.analysis.deck_report, visnav.analysis.witas_metrics  # noqa: E401, F401

    original = report._fig_to_img  # every report module that took it at import
    for mod in [m for name, m in sys.modules.items() if name.startswith("visnav.")]:
        if getattr(mod, "_fig_to_img", None) is original:
            monkeypatch.setattr(mod, "_fig_to_img", keep)
    yield made
    for f in made:
        plt.close(f)


def _run(name, over):
    res = make_simulation(load_scenario(name, over)).run()
    assert res.error is None
    return res


def _contrast(c1, c2) -> float:
    """WCAG 2.1 contrast ratio of two colours (1: identical luminance, 21: black on white)."""
    def lum(c):
        rgb = np.array(to_rgba(c)[:3])
        lin = np.where(rgb <= 0.03928, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
        return float(lin @ [0.2126, 0.7152, 0.0722])
    a, b = sorted((lum(c1), lum(c2)))
    return (b + 0.05) / (a + 0.05)


def _points_under_legends(fig) -> int:
    """(Draw the figure first.) Line vertices that a legend covers."""
    n = 0
    for ax in fig.axes:
        for leg in [ax.get_legend()] + list(fig.legends):
            if leg is None:
                continue
            bb = leg.get_window_extent()
            for line in ax.get_lines():
                x, y = line.get_transform().transform(np.asarray(line.get_xydata(), float)).T
                n += int(np.sum((x >= bb.x0) & (x <= bb.x1) & (y >= bb.y0) & (y <= bb.y1)))
    return n


def _labels_inside_other_axes(fig) -> list[str]:
    """(Draw the figure first.) Tick and axis labels of one axes (colour bars included) that reach into another
    axes' panel."""
    r = fig.canvas.get_renderer()
    bad = []
    for ax in fig.axes:
        texts = [t for t in ax.get_xticklabels() + ax.get_yticklabels() + [ax.yaxis.label] if t.get_text()]
        for t in texts:
            bb = t.get_window_extent(r)
            for other in fig.axes:
                if other is not ax and bb.overlaps(other.get_window_extent(r)):
                    bad.append(t.get_text())
    return bad


def test_palace_plots_have_a_legend_for_the_mode_bands(figures):
    res = _run("palace-landing", ["run.duration_s=6"])
    titles = [t for t, _ in report.plots(res.log)]
    fig = figures[titles.index("Errors and modes")]
    assert fig.legends, "no legend for the mode bands"
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    modes = [m for m in dict.fromkeys(res.log.get("mode")["mode"]) if m in report.MODE_COLORS]
    assert labels == [f"mode: {m}" for m in modes] and "mode: descend_gps" in labels
    for patch, m in zip(fig.legends[0].get_patches(), modes):
        assert np.allclose(patch.get_facecolor()[:3], to_rgba(report.MODE_COLORS[m])[:3])


def test_witas_track_legend_entries_are_visible_on_the_legend(figures):
    from visnav.analysis import witas_metrics

    res = _run("witas-homing", ["run.duration_s=11", "mission.gps_loss_s=3", "mission.settle_s=1"])
    witas_metrics.plots(res.log, res.scenario)
    leg = figures[0].axes[0].get_legend()
    labels = [t.get_text() for t in leg.get_texts()]
    assert {"odometry only", "INS only", "PMF"} <= set(labels)
    bg = leg.get_frame().get_facecolor()
    for h, label in zip(leg.legend_handles, labels):
        c = h.get_color() if hasattr(h, "get_color") else h.get_facecolor()
        if label == "home":
            c = h.get_markerfacecolor()
        assert _contrast(c, bg) >= 3.0, f"{label!r} in {c} on {bg}"  # WCAG 1.4.11 non-text contrast


def test_deck_plots_put_the_error_on_its_own_axis_in_degrees_with_legends_off_the_data(figures):
    from visnav.analysis import deck_report

    res = _run("deck-static", ["run.duration_s=3"])
    titles = [t for t, _ in deck_report.plots(res.log, res.scenario)]
    for k, title in enumerate(titles):
        fig = figures[k]
        fig.canvas.draw()
        assert _points_under_legends(fig) == 0, title
        assert _labels_inside_other_axes(fig) == [], title
        if title.startswith("Estimate vs truth"):
            ax = np.array(fig.axes).reshape(3, 2)
            for i in range(3):
                left = {line.get_label() for line in ax[i, 0].get_lines()}
                right = {line.get_label() for line in ax[i, 1].get_lines()}
                assert left == {"estimate", "truth"} and right == {"estimate - truth"}
            if "attitude" in title:
                assert all("[deg]" in a.get_ylabel() for a in fig.axes)
                err = ax[0, 1].get_lines()[0].get_ydata()
                es, tr = res.log.get("estimate"), res.log.get("truth")
                want = np.degrees((es["euler"][:, 0] - tr["euler"][:, 0] + np.pi) % (2 * np.pi) - np.pi)
                assert np.allclose(err, want)
    norms = figures[titles.index("Error norms against distance (final approach)")]
    ylabels = [a.get_ylabel() for a in norms.axes]
    assert "|attitude error| [deg]" in ylabels and "|deck_rates error| [deg/s]" in ylabels
    assert not any("rad" in y for y in ylabels)


def test_condor_colour_bar_labels_do_not_reach_into_the_next_panel():
    from visnav.analysis.condor_report import _error_map_figure

    fig = _error_map_figure(load_scenario("condor-orbit"))
    try:
        fig.canvas.draw()
        assert _labels_inside_other_axes(fig) == []
    finally:
        plt.close(fig)


def _orbit_log(amp=27.5, mean=7.5, period=6.0, switch=60.0):
    log = FlightLog()
    log.record("mode", 0.0, mode="gps_loiter", reason="")
    log.record("mode", switch, mode="vision_orbit", reason="")
    for t in np.arange(0.0, 240.0, 0.1):
        phi = 15.0 if t < switch else mean + amp * math.sin(2 * math.pi * t / period)
        log.record("truth", t, euler=np.radians([phi, 0.0, 0.0]), airspeed=18.0)
    return log


def test_condor_bank_limit_cycle_is_measured_and_stated():
    from visnav.analysis import condor_report

    sc = load_scenario("condor-orbit")
    b = condor_report.bank_oscillation(_orbit_log(), sc.mission)
    assert b["min_deg"] == pytest.approx(-20.0, abs=0.05) and b["max_deg"] == pytest.approx(35.0, abs=0.05)
    assert b["period_s"] == pytest.approx(6.0, abs=0.2)
    assert b["steady_deg"] == pytest.approx(math.degrees(math.atan(18.0**2 / (9.80665 * 110.0))), abs=1e-9)
    assert b["loiter_p5_deg"] == pytest.approx(15.0) and b["loiter_p95_deg"] == pytest.approx(15.0)
    result = SimpleNamespace(scenario=sc, log=_orbit_log(), metrics={})
    lines = report.run_notes(result)
    assert len(lines) == 1 and "between -20.0 and 35.0 deg" in lines[0]
    assert f"dominant period {b['period_s']:.1f} s" in lines[0]
    calm = _orbit_log(amp=0.5, mean=15.0)
    assert "between 14.5 and 15.5 deg" in condor_report.notes(calm, sc, {})[0]
