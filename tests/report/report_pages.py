"""The report room's page check on rendered PDF pages (a helper module, imported by the
report tests: ``from report_pages import pages_whole``)."""

import shutil
import subprocess

import numpy as np
import pytest

from rasc.report import PAGES


def pages_whole(pdf, folder) -> None:
    """Each page rendered (pdftoppm, 50 dpi) has ink, and none within 1 % of its edges:
    nothing drawn off the page (a cropped line or axis label touches the border)."""
    if shutil.which("pdftoppm") is None:
        pytest.skip("pdftoppm (poppler-utils) not installed: pages not rendered to PNG "
                    "(the page count was checked)")
    subprocess.run(["pdftoppm", "-png", "-r", "50", str(pdf), str(folder / "page")],
                   check=True, timeout=120)
    import cv2

    pngs = sorted(folder.glob("page-*.png"))
    assert len(pngs) == PAGES
    for p in pngs:
        img = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        assert img is not None and img.shape[1] > 400
        assert np.mean(img < 200) > 0.005, p.name            # a page of text or plots
        h, w = img.shape
        dy, dx = max(1, h // 100), max(1, w // 100)
        border = np.concatenate([img[:dy].ravel(), img[-dy:].ravel(), img[:, :dx].ravel(),
                                 img[:, -dx:].ravel()])
        assert np.all(border >= 200), f"{p.name}: ink at the page's edge (cropped?)"
