"""Text on ``rgb_array`` frames: a 5 x 7 pixel bitmap font (numpy only, no font files).

The glyphs cover what the frame captions and bar labels print: digits, ``. - + / : %`` and
the lowercase letters of the units and labels (``t s v km/h a m/s2 x g peak displ``, ``time``,
``force``, ``front``, ``rear``). A character without a glyph is drawn as a blank.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["GLYPHS", "draw_text", "text_width"]

_ROWS = """
0 .###. #...# #..## #.#.# ##..# #...# .###.
1 ..#.. .##.. ..#.. ..#.. ..#.. ..#.. .###.
2 .###. #...# ....# ...#. ..#.. .#... #####
3 ##### ...#. ..#.. ...#. ....# #...# .###.
4 ...#. ..##. .#.#. #..#. ##### ...#. ...#.
5 ##### #.... ####. ....# ....# #...# .###.
6 ..##. .#... #.... ####. #...# #...# .###.
7 ##### ....# ...#. ..#.. .#... .#... .#...
8 .###. #...# #...# .###. #...# #...# .###.
9 .###. #...# #...# .#### ....# ...#. .##..
. ..... ..... ..... ..... ..... .##.. .##..
- ..... ..... ..... ##### ..... ..... .....
+ ..... ..#.. ..#.. ##### ..#.. ..#.. .....
/ ..... ....# ...#. ..#.. .#... #.... .....
: ..... .##.. .##.. ..... .##.. .##.. .....
% ##..# ##..# ...#. ..#.. .#... #..## #..##
a ..... ..... .###. ....# .#### #...# .####
c ..... ..... .###. #.... #.... #...# .###.
d ....# ....# .##.# #..## #...# #...# .####
e ..... ..... .###. #...# ##### #.... .###.
f ..##. .#..# .#... ###.. .#... .#... .#...
g ..... .#### #...# #...# .#### ....# .###.
h #.... #.... #.##. ##..# #...# #...# #...#
i ..#.. ..... .##.. ..#.. ..#.. ..#.. .###.
k #.... #.... #..#. #.#.. ##... #.#.. #..#.
l .##.. ..#.. ..#.. ..#.. ..#.. ..#.. .###.
m ..... ..... ##.#. #.#.# #.#.# #...# #...#
n ..... ..... #.##. ##..# #...# #...# #...#
o ..... ..... .###. #...# #...# #...# .###.
p ..... ..... ####. #...# ####. #.... #....
r ..... ..... #.##. ##..# #.... #.... #....
s ..... ..... .#### #.... .###. ....# ####.
t .#... .#... ###.. .#... .#... .#..# ..##.
v ..... ..... #...# #...# #...# .#.#. ..#..
x ..... ..... #...# .#.#. ..#.. .#.#. #...#
"""

#: character → (7, 5) bool array of its pixels
GLYPHS: dict[str, np.ndarray] = {
    line[0]: np.array([[c == "#" for c in row] for row in line[2:].split()], dtype=bool)
    for line in _ROWS.strip().splitlines()
}
_ADVANCE = 6  # glyph width plus one column of spacing, in font pixels


def text_width(text: str, scale: int = 1) -> int:
    """Width in px of ``text`` drawn at ``scale``."""
    return max(len(text) * _ADVANCE - 1, 0) * scale


def draw_text(
    img: np.ndarray, x: float, y: float, text: str, color: Sequence[int], scale: int = 1
) -> None:
    """Draw ``text`` with its top-left corner at pixel ``(x, y)``, each font pixel a
    ``scale`` x ``scale`` square; clipped at the borders of ``img`` (H, W, 3)."""
    h, w = img.shape[:2]
    rgb = np.asarray(color, dtype=np.uint8)
    x0, y0 = int(round(x)), int(round(y))
    for n, char in enumerate(text):
        glyph = GLYPHS.get(char)
        if glyph is None:
            continue
        big = np.repeat(np.repeat(glyph, scale, axis=0), scale, axis=1)
        gx = x0 + n * _ADVANCE * scale
        r0, c0 = max(y0, 0), max(gx, 0)
        r1, c1 = min(y0 + big.shape[0], h), min(gx + big.shape[1], w)
        if r0 >= r1 or c0 >= c1:
            continue
        mask = big[r0 - y0 : r1 - y0, c0 - gx : c1 - gx]
        img[r0:r1, c0:c1][mask] = rgb
