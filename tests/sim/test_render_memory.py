"""The renderer into memory: the dataset rasc.sim.render.render_in_memory holds is the
one render_dataset writes (the same bytes once written), and its corners detected from
the arrays are those detected from the PNG files."""

import numpy as np
import pytest

from rasc.sim.render import RenderOptions, render_dataset, render_in_memory
from rasc.vision import load_dataset, write_dataset
from rasc.vision.board import parse_target
from rasc.vision.dataset import forget_detections

SMALL = RenderOptions(intrinsics_views=3, poses_deg=((0, 0), (8, 0), (0, 8)), seed=4,
                      image_noise=2.0, blur=0.7)


@pytest.mark.slow
@pytest.mark.parametrize("target", [None, "charuco:12x9,0.06,0.045"])
def test_in_memory_render_is_the_folder_render(tmp_path, target):
    board = None if target is None else parse_target(target)
    render_dataset(tmp_path / "folder", SMALL, quiet=True, board=board)
    memory = render_in_memory(SMALL, quiet=True, board=board)
    assert memory.options == SMALL and memory.pixels is not None
    write_dataset(memory, tmp_path / "written")
    files = sorted(p.relative_to(tmp_path / "folder")
                   for p in (tmp_path / "folder").rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(tmp_path / "written")
                           for p in (tmp_path / "written").rglob("*") if p.is_file())
    for f in files:          # images, manifest, ground truth: byte for byte
        assert (tmp_path / "folder" / f).read_bytes() == \
            (tmp_path / "written" / f).read_bytes(), f
    folder = load_dataset(tmp_path / "folder")
    assert memory.load_ground_truth() == folder.load_ground_truth()
    forget_detections()
    for eye in ("left", "right"):
        for role in ("intrinsics", "pose"):
            a, b = memory.detect(eye, role), folder.detect(eye, role)
            assert list(a.corners) == list(b.corners) and a.corners
            for f in a.corners:       # PNG is lossless: the very same corners
                np.testing.assert_array_equal(a.corners[f], b.corners[f])
