"""The renderer's texture of a target (rasc.sim.mjcf.texture_image): dense enough, and the
target's own drawing."""

from __future__ import annotations

import numpy as np

from rasc.sim.mjcf import MIN_TEXELS_PER_METRE, texture_image
from rasc.vision.board import CharucoBoard


def test_texture_is_the_drawing_repeated_to_the_density():
    for board in (CharucoBoard((12, 9), 0.06, 0.045), CharucoBoard((5, 4), 0.17, 0.127)):
        art = board.texture()
        tex = texture_image(board)
        k = tex.shape[1] // art.shape[1]
        assert tex.shape == (k * art.shape[0], k * art.shape[1])
        width = board.squares[0] * board.square_size
        # dense enough, and the smallest such repeat
        assert tex.shape[1] / width >= MIN_TEXELS_PER_METRE
        assert k == 1 or (k - 1) * art.shape[1] / width < MIN_TEXELS_PER_METRE
        # every k x k block is one texel of the drawing, rows reversed for MuJoCo
        blocks = tex[::-1].reshape(art.shape[0], k, art.shape[1], k)
        assert np.all(blocks == art[:, None, :, None])
    # 120 texels per 60 mm square is 2000 per metre: the 12x9 board is drawn as before
    assert texture_image(CharucoBoard((12, 9), 0.06, 0.045)).shape == (1080, 1440)
    assert texture_image(CharucoBoard((5, 4), 0.17, 0.127)).shape[1] == 3 * 600
