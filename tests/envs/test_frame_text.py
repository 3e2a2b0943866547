"""Text on the envs' frames: the bitmap font and the caption (time, speed, acceleration,
exaggeration factor) of each env's ``render()``."""

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from railgym.envs.raster import CRASH_COLORS, VERTICAL_COLORS, canvas
from railgym.envs.text import GLYPHS, draw_text, text_width


def test_glyphs_are_drawn_pixel_for_pixel_and_scaled():
    img = canvas(40, 20, (255, 255, 255))
    draw_text(img, 3, 2, "8", (0, 0, 0))
    on = np.all(img == 0, axis=2)
    np.testing.assert_array_equal(on[2:9, 3:8], GLYPHS["8"])
    assert on.sum() == GLYPHS["8"].sum()  # nothing outside the glyph box
    big = canvas(40, 20, (255, 255, 255))
    draw_text(big, 0, 0, "1", (0, 0, 0), scale=2)
    assert np.all(big == 0, axis=2).sum() == 4 * GLYPHS["1"].sum()
    assert text_width("12", 2) == 22


def test_text_clips_at_the_borders():
    img = canvas(10, 6, (255, 255, 255))
    draw_text(img, -3, -2, "0123456789", (0, 0, 0))  # partly outside: no error
    draw_text(img, 50, 50, "0", (0, 0, 0))  # wholly outside: nothing drawn
    assert 0 < np.all(img == 0, axis=2).sum() < 10 * 6


def _caption_band(frame, text, color):
    """The caption band of ``frame`` and the same band with ``text`` drawn alone on the
    frame's own background pixels."""
    scale = max(1, frame.shape[0] // 300)
    rows = slice(20, 20 + 7 * scale)
    band = frame[rows].copy()
    expected = band.copy()
    mask = np.all(band == np.asarray(color, np.uint8), axis=2)
    expected[mask] = VERTICAL_COLORS["background"]  # erase the text, keep the rest
    alone = np.zeros((frame.shape[0], frame.shape[1], 3), np.uint8)
    alone[rows] = expected
    draw_text(alone, 6, 20, text, color, scale)
    return band, alone[rows]


@pytest.mark.parametrize(
    ("env_id", "actions", "exaggeration"),
    [
        ("railgym/VerticalSuspension-v1", 1, "100"),
        ("railgym/VerticalVehicle-v1", 2, None),
    ],
)
def test_frames_carry_time_speed_acceleration_and_exaggeration(env_id, actions, exaggeration):
    env = gym.make(env_id, render_mode="rgb_array", duration=1.0)
    env.reset(seed=3)
    for _ in range(37):
        _, _, _, _, info = env.step(np.zeros(actions, np.float32))
    frame = env.render()
    acc = np.atleast_1d(info["carbody_acc"])  # the vehicle's centre floor point
    acc = acc[acc.size // 2]
    state = env.unwrapped.sim.render_state(0)
    words = [f"t {info['time']:.3f} s", f"v {3.6 * state['speed']:.0f} km/h"]
    words.append(f"a {acc:+.2f} m/s2")
    if exaggeration is None:  # the vehicle: heights over lengths of its own drawing
        span = state["track_x"][-1] - state["track_x"][0]
        exaggeration = f"{2000.0 * frame.shape[0] / 400 / (frame.shape[1] / span):.0f}"
    words.append(f"displ x{exaggeration}")
    text = "   ".join(words)
    band, expected = _caption_band(frame, text, VERTICAL_COLORS["outline"])
    np.testing.assert_array_equal(band, expected)
    assert words[0] == "t 0.370 s" and words[1] == "v 144 km/h"


def test_crash_frame_carries_time_and_speed():
    env = gym.make("railgym/TrainCrash-v1", render_mode="rgb_array")
    env.reset(seed=0)
    frame0 = env.render()
    env.step(np.zeros(env.action_space.shape, np.float32))
    frame1 = env.render()
    rows = slice(20, 27)
    assert np.any(frame0[rows] != frame1[rows])  # the time changed
    text = np.all(frame1[rows] == np.asarray(CRASH_COLORS["wall"], np.uint8), axis=2)
    assert text[:, :6].sum() == 0 and text[:, 6 : 6 + text_width("t 0.000 s")].sum() > 0
