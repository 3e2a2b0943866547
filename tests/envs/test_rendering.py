"""Tests for railgym.envs.raster (primitives) and the frames of the vertical vehicle, the whole
vehicle and the crash."""

import math

import numpy as np
import pytest

from railgym.envs.crash.render import render_crash
from railgym.envs.raster import (
    BAR_ROWS,
    CRASH_COLORS,
    DISPLACEMENT_PX_PER_M,
    VERTICAL_COLORS,
    bar_columns,
    canvas,
    draw_damper,
    draw_line,
    draw_polyline,
    draw_spring,
    fill_circle,
    fill_rect,
)
from railgym.envs.text import GLYPHS, draw_text, text_width
from railgym.envs.vertical.render import render_vertical

INK = (255, 0, 0)


def mask_of(img, color):
    return np.all(img == np.asarray(color, dtype=np.uint8), axis=2)


def blank(w=120, h=80):
    return canvas(w, h, (0, 0, 0))


# --------------------------------------------------------------------------- primitives
def test_canvas_shape_dtype_colour():
    img = canvas(7, 5, (1, 2, 3))
    assert img.shape == (5, 7, 3) and img.dtype == np.uint8
    assert np.all(img == np.array([1, 2, 3], dtype=np.uint8))
    with pytest.raises(ValueError, match="width"):
        canvas(0, 5)
    with pytest.raises(ValueError, match="color"):
        canvas(5, 5, (0, 0, 300))


def test_fill_rect_pixel_centres():
    img = blank()
    fill_rect(img, 30, 25, 10, 20, INK)  # corners in any order
    m = mask_of(img, INK)
    assert m.sum() == 20 * 5
    assert m[20:25, 10:30].all()


def test_draw_line_diagonal_and_width():
    img = blank(100, 100)
    draw_line(img, 0.5, 0.5, 99.5, 99.5, INK)
    np.testing.assert_array_equal(mask_of(img, INK), np.eye(100, dtype=bool))
    img = blank()
    draw_line(img, 10.5, 40.5, 60.5, 40.5, INK, width=3)
    rows = np.nonzero(mask_of(img, INK).any(axis=1))[0]
    np.testing.assert_array_equal(rows, [39, 40, 41])


def test_steep_line_is_connected():
    img = blank()
    draw_line(img, 10.2, 3.7, 17.9, 70.1, INK)
    m = mask_of(img, INK)
    counts = m[3:71].sum(axis=1)
    assert np.all(counts == 1)  # one pixel per row, no gaps
    assert m.sum() == 68


def test_polyline_square_outline():
    img = blank()
    xs = [10.5, 50.5, 50.5, 10.5, 10.5]
    ys = [10.5, 10.5, 50.5, 50.5, 10.5]
    draw_polyline(img, xs, ys, INK)
    m = mask_of(img, INK)
    assert m.sum() == 4 * 40
    assert not m[11:50, 11:50].any()
    with pytest.raises(ValueError, match="ys"):
        draw_polyline(img, xs, ys[:-1], INK)
    with pytest.raises(ValueError, match="xs"):
        draw_polyline(img, [1.0], [1.0], INK)


def test_spring_extent_and_coils():
    img = blank(120, 260)
    coils, amp = 4, 10.0
    draw_spring(img, 60.5, 20.5, 220.5, INK, coils=coils, amplitude=amp)
    m = mask_of(img, INK)
    rows, cols = np.nonzero(m)
    assert rows.min() == 20 and rows.max() == 220
    assert cols.min() == math.floor(60.5 - amp) and cols.max() == math.floor(60.5 + amp)
    centre = np.array([np.nonzero(r)[0].mean() for r in m[20:221]])
    slope = np.sign(np.diff(centre))
    slope = slope[slope != 0]
    turns = np.count_nonzero(np.diff(slope))
    assert turns == 2 * coils


def test_damper_stays_in_its_box():
    img = blank(120, 200)
    draw_damper(img, 60.5, 20.5, 180.5, INK, half_width=8, width=1)
    rows, cols = np.nonzero(mask_of(img, INK))
    assert rows.min() == 20 and rows.max() == 180
    assert cols.min() == math.floor(60.5 - 8) and cols.max() == math.floor(60.5 + 8)
    assert mask_of(img, INK)[180, 52:69].all()  # cylinder bottom


def test_fill_circle_area():
    img = blank(200, 200)
    fill_circle(img, 100.0, 100.0, 40.0, INK)
    area = mask_of(img, INK).sum()
    assert abs(area / (math.pi * 40.0**2) - 1.0) < 0.01


@pytest.mark.parametrize("far", [1e12, np.inf])
def test_primitives_clip_far_coordinates(far):
    img = blank()
    fill_rect(img, -far, -far, far, 10, INK)
    assert mask_of(img, INK).sum() == 120 * 10
    img = blank()
    draw_line(img, -far, 40.5, far, 40.5, INK)
    m = mask_of(img, INK)
    assert m[40].all() and m.sum() == 120
    img = blank()
    draw_line(img, -far, -50, far, -50, INK, width=3)  # entirely outside
    draw_polyline(img, [-far, far, far], [-far, -far, far], INK, width=2)
    fill_circle(img, far, far, 5, INK)
    draw_spring(img, far, -far, far, INK)
    draw_damper(img, -far, 10, 20, INK)
    assert not mask_of(img, INK).any()
    with pytest.raises(ValueError, match="NaN"):
        draw_line(img, np.nan, 0, 1, 1, INK)


# --------------------------------------------------------------------------- vertical scene
def vertical_state(**kw):
    tx = np.linspace(100.0, 130.0, 301)
    state = dict(
        x1=0.0,
        x2=0.0,
        z=0.0,
        track_x=tx,
        track_z=np.zeros_like(tx),
        time=2.0,
        force_a=0.0,
        f_max=5e3,
    )
    state.update(kw)
    return state


def centroid_row(img, color):
    rows, _ = np.nonzero(mask_of(img, color))
    assert rows.size > 0
    return rows.mean()


@pytest.mark.parametrize("height", [400, 200])
def test_vertical_shape_and_carbody_moves_up(height):
    k = DISPLACEMENT_PX_PER_M * height / 400
    a = render_vertical(vertical_state(), 600, height)
    b = render_vertical(vertical_state(x2=0.01), 600, height)
    assert a.shape == (height, 600, 3) and a.dtype == np.uint8
    body = VERTICAL_COLORS["carbody"]
    shift = centroid_row(a, body) - centroid_row(b, body)
    assert shift == pytest.approx(0.01 * k, abs=0.5)


def test_vertical_bogie_and_wheel_follow_x1_and_z():
    k = DISPLACEMENT_PX_PER_M
    ref = render_vertical(vertical_state())
    bogie = render_vertical(vertical_state(x1=0.004))
    wheel = render_vertical(vertical_state(z=0.003))
    c = VERTICAL_COLORS
    dy = centroid_row(ref, c["bogie"]) - centroid_row(bogie, c["bogie"])
    assert dy == pytest.approx(0.004 * k, abs=0.5)
    np.testing.assert_array_equal(mask_of(ref, c["carbody"]), mask_of(bogie, c["carbody"]))
    dy = centroid_row(ref, c["wheel"]) - centroid_row(wheel, c["wheel"])
    assert dy == pytest.approx(0.003 * k, abs=0.5)


def rail_top(img, column):
    return np.nonzero(mask_of(img, VERTICAL_COLORS["rail"])[:, column])[0].min()


def test_vertical_track_profile_exaggerated_and_placed():
    k = DISPLACEMENT_PX_PER_M
    flat = render_vertical(vertical_state())
    raised = render_vertical(vertical_state(track_z=np.full(301, 0.005)))
    assert rail_top(flat, 5) - rail_top(raised, 5) == pytest.approx(0.005 * k, abs=1)
    # a 1 m bump 5 m ahead of the vehicle at s = 110 m (30 m window over 600 px)
    tx = np.linspace(100.0, 130.0, 301)
    bump = np.where(np.abs(tx - 115.0) <= 0.5, 0.005, 0.0)
    img = render_vertical(vertical_state(track_z=bump, s=110.0))
    col = int(300 + 5.0 * 600 / 30)
    assert rail_top(flat, col) - rail_top(img, col) == pytest.approx(0.005 * k, abs=1)
    assert rail_top(img, col + 30) == rail_top(flat, col + 30)


@pytest.mark.parametrize("ratio", [1.0, 0.5, -0.7])
def test_vertical_actuator_arrow_and_gauge(ratio):
    img = render_vertical(vertical_state(force_a=ratio * 5e3))
    c = VERTICAL_COLORS
    on, off = (
        ("actuator_push", "actuator_pull") if ratio > 0 else ("actuator_pull", "actuator_push")
    )
    assert not mask_of(img, c[off]).any()
    m = mask_of(img, c[on])
    arrow_rows = np.nonzero(m[20:].any(axis=1))[0]
    assert np.ptp(arrow_rows) + 1 == pytest.approx(0.45 * 0.14 * 400 * abs(ratio), abs=1.5)
    # the gauge under the progress bar: from its zero mark at the middle of the bar columns,
    # full scale half their width, to the right when pushing
    x0, x1 = bar_columns(600)
    centre = (x0 + x1) // 2
    half = min(centre - x0, x1 - centre)
    gauge_cols = np.nonzero(m[13])[0]
    assert gauge_cols.size == pytest.approx(abs(ratio) * half, abs=1)
    assert (gauge_cols.min() >= centre) == (ratio > 0)
    track = mask_of(img, c["bar_back"])[13] | m[13]
    track[centre] = True  # the zero mark
    assert np.nonzero(track)[0].tolist() == list(range(centre - half, centre + half))


def test_vertical_force_saturates_and_progress_bar():
    a = render_vertical(vertical_state(force_a=5e3))
    b = render_vertical(vertical_state(force_a=9e3))
    np.testing.assert_array_equal(a, b)
    img = render_vertical(vertical_state(time=2.5, duration=10.0))
    x0, x1 = bar_columns(600)
    filled = mask_of(img, VERTICAL_COLORS["bar_front"])[5]
    empty = mask_of(img, VERTICAL_COLORS["bar_back"])[5]
    assert filled.sum() == pytest.approx(0.25 * (x1 - x0), abs=1)
    assert np.nonzero(filled | empty)[0].tolist() == list(range(x0, x1))


def test_vertical_is_deterministic_and_leaves_state_alone():
    tx = np.linspace(0.0, 30.0, 301)
    state = vertical_state(
        x1=0.002, x2=-0.004, z=0.001, track_x=tx, track_z=0.003 * np.sin(tx), force_a=-1.2e3
    )
    before = state["track_z"].copy()
    np.testing.assert_array_equal(render_vertical(state), render_vertical(state))
    np.testing.assert_array_equal(state["track_z"], before)


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"x1": np.nan}, "x1"),
        ({"force_a": "big"}, "force_a"),
        ({"f_max": 0.0}, "f_max"),
        ({"track_x": np.linspace(30.0, 0.0, 301)}, "track_x"),
        ({"track_z": np.zeros(5)}, "track_z"),
        ({"duration": -1.0}, "duration"),
    ],
)
def test_vertical_bad_input(change, field):
    with pytest.raises(ValueError, match=field):
        render_vertical(vertical_state(**change))
    state = vertical_state()
    del state["x2"]
    with pytest.raises(ValueError, match="x2"):
        render_vertical(state)


def test_scenes_survive_absurd_states():
    img = render_vertical(vertical_state(x1=1e3, x2=-1e3, z=1e6, force_a=-1e9), 64, 48)
    assert img.shape == (48, 64, 3)
    assert not mask_of(img, VERTICAL_COLORS["wheel"]).any()  # wheel far above the frame
    img = render_crash(crash_state(positions=np.array([1e9]), crush=np.array([-3.0])), 50, 40)
    assert img.shape == (40, 50, 3)
    assert not mask_of(img, CRASH_COLORS["car"]).any()


# --------------------------------------------------------------------------- crash scene
def crash_state(**kw):
    state = dict(
        positions=np.array([0.0]),
        lengths=np.array([10.0]),
        crush=np.array([0.5]),
        stroke=np.array([2.0]),
        wall_x=0.0,
        view=(-11.0, 1.0),
    )
    state.update(kw)
    return state


def zone_columns(img, color):
    return np.nonzero(mask_of(img, color).any(axis=0))[0]


def test_crash_shape_and_crush_shortens_zone():
    sx = 800 / 12.0
    a = render_crash(crash_state())
    b = render_crash(crash_state(crush=np.array([1.0])))
    assert a.shape == (300, 800, 3) and a.dtype == np.uint8
    zone = CRASH_COLORS["zone"]
    ca, cb = zone_columns(a, zone), zone_columns(b, zone)
    assert ca.size == pytest.approx(1.5 * sx, abs=1)
    assert cb.size == pytest.approx(1.0 * sx, abs=1)
    assert mask_of(b, zone).sum() < mask_of(a, zone).sum()
    assert ca.min() == cb.min()  # the zone starts at the fixed end (front - stroke)
    assert not mask_of(a, CRASH_COLORS["zone_overloaded"]).any()


def test_crash_overloaded_zone_turns_red():
    sx = 800 / 12.0
    img = render_crash(crash_state(crush=np.array([2.5])))
    assert not mask_of(img, CRASH_COLORS["zone"]).any()
    red = zone_columns(img, CRASH_COLORS["zone_overloaded"])
    assert red.size == 3
    assert red.max() + 1 == pytest.approx((11.0 - 2.5) * sx, abs=1)


def test_crash_interface_zone_and_default_view():
    state = dict(
        positions=np.array([0.2, -27.5]),
        lengths=np.array([27.6, 24.5]),
        crush=np.array([0.2, 0.1]),
        stroke=np.array([0.9, 0.6]),
        wall_x=0.0,
    )
    img = render_crash(state)
    zone = mask_of(img, CRASH_COLORS["zone"])
    labels = np.diff(np.concatenate(([0], zone.any(axis=0).astype(int)))) == 1
    assert labels.sum() == 2  # two separate zones: lead car front and interface
    wall = zone_columns(img, CRASH_COLORS["wall"])
    car = zone_columns(img, CRASH_COLORS["car"])
    assert 0 < car.min() and car.max() < wall.min() < 799
    # the lead car's deformed front touches the wall face: crush = position - wall_x
    assert zone_columns(img, CRASH_COLORS["zone"]).max() + 1 == wall.min()


def test_crash_is_deterministic():
    state = crash_state(
        positions=np.array([0.3, -10.4]),
        lengths=np.array([10.0, 9.0]),
        crush=np.array([0.3, 0.2]),
        stroke=np.array([1.0, 0.5]),
        view=(-21.0, 2.0),
    )
    np.testing.assert_array_equal(render_crash(state), render_crash(state))


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"lengths": np.array([10.0, 10.0])}, "lengths"),
        ({"stroke": np.array([12.0])}, "stroke"),
        ({"view": (1.0, -11.0)}, "view"),
        ({"wall_x": np.inf}, "wall_x"),
        ({"crush": np.array([np.nan])}, "crush"),
    ],
)
def test_crash_bad_input(change, field):
    with pytest.raises(ValueError, match=field):
        render_crash(crash_state(**change))


# --------------------------------------------------------------------------- bar labels
def _label_box(img, text, x_end, rows, color, background):
    """The pixels of ``text`` as the frames draw a bar's label (ending 4 px left of column
    ``x_end``, centred on ``rows``): (region of ``img``, the same region with the text drawn
    alone on ``background``)."""
    y = round(0.5 * (rows[0] + rows[1]) - 3.5)
    x = round(x_end - 4 - text_width(text))
    region = (slice(y, y + 7), slice(max(x, 0), x_end - 4))
    alone = canvas(img.shape[1], img.shape[0], background)
    draw_text(alone, x, y, text, color)
    return img[region], alone[region]


def test_the_vertical_frames_bars_carry_their_labels():
    img = render_vertical(vertical_state(time=2.5, duration=10.0, force_a=2.5e3))
    c = VERTICAL_COLORS
    x0, x1 = bar_columns(600)
    centre = (x0 + x1) // 2
    gauge_start = centre - min(centre - x0, x1 - centre)
    for text, x_end in (("time", x0), ("force", gauge_start)):
        got, want = _label_box(img, text, x_end, BAR_ROWS[text], c["outline"], c["background"])
        np.testing.assert_array_equal(got, want)
        assert mask_of(got, c["outline"]).sum() == sum(GLYPHS[ch].sum() for ch in text)


def test_the_crash_frames_progress_bar_carries_its_label():
    img = render_crash(crash_state(time=0.1, duration=1.0))
    x0, _ = bar_columns(800)
    c = CRASH_COLORS
    got, want = _label_box(img, "time", x0, BAR_ROWS["time"], c["wall"], c["background"])
    np.testing.assert_array_equal(got, want)
    assert mask_of(got, c["wall"]).any()


def _vehicle_state(**kw):
    from railgym.envs.vehicle.render import render_vehicle  # noqa: F401  (the module tested)

    tx = np.linspace(-18.0, 18.0, 301)
    state = {
        "track_x": tx,
        "track_z": np.zeros_like(tx),
        "body_x": np.linspace(-12.0, 12.0, 41),
        "body_z": np.zeros(41),
        "bogie_x": np.array([9.5, -9.5]),
        "bogie_z": np.zeros(2),
        "bogie_pitch": np.zeros(2),
        "wheel_x": np.array([10.75, 8.25, -8.25, -10.75]),
        "wheel_z": np.zeros(4),
        "force": np.array([4e3, -2e3]),
        "f_max": 8e3,
        "time": 1.0,
        "duration": 4.0,
    }
    state.update(kw)
    return state


def test_the_vehicle_frames_bars_carry_their_labels():
    """The progress bar (``time``) and a gauge above each bogie (``front force`` over the
    bogie at the larger position, ``rear force``), each filled from its zero mark."""
    from railgym.envs.vehicle.render import render_vehicle

    img = render_vehicle(_vehicle_state())
    c = VERTICAL_COLORS
    x0, _ = bar_columns(800)
    got, want = _label_box(img, "time", x0, BAR_ROWS["time"], c["outline"], c["background"])
    np.testing.assert_array_equal(got, want)
    half = round(0.08 * 800)
    for x, text, ratio in ((9.5, "front force", 0.5), (-9.5, "rear force", -0.25)):
        centre = round((x + 18.0) * 800 / 36.0)
        box = _label_box(img, text, centre - half, BAR_ROWS["force"], c["outline"], c["background"])
        np.testing.assert_array_equal(*box)
        row = img[13]
        push = np.nonzero(np.all(row == c["actuator_push"], axis=1))[0]
        pull = np.nonzero(np.all(row == c["actuator_pull"], axis=1))[0]
        filled = push[(push >= centre - half) & (push < centre + half)]
        if ratio < 0:
            filled = pull[(pull >= centre - half) & (pull < centre + half)]
        assert filled.size == pytest.approx(abs(ratio) * half, abs=1)
        assert (filled.min() >= centre) == (ratio > 0)


def test_the_frames_draw_their_bar_labels_through_the_font(monkeypatch):
    """Every label goes through the font's draw_text (no label drawn by hand)."""
    import railgym.envs.raster as raster
    from railgym.envs.vehicle.render import render_vehicle

    drawn: list[str] = []

    def record(img, x, y, text, color, scale=1):
        drawn.append(text)
        draw_text(img, x, y, text, color, scale)

    monkeypatch.setattr(raster, "draw_text", record)
    render_vertical(vertical_state(duration=10.0))
    assert drawn[:2] == ["time", "force"]
    drawn.clear()
    render_vehicle(_vehicle_state())
    assert {"time", "front force", "rear force"} <= set(drawn)
    drawn.clear()
    render_crash(crash_state(time=0.0))
    assert "time" in drawn
