"""The report room's rig: ``rasc_cli`` (rasc in this process): fixtures of
:mod:`shared_fixtures` (see there); ``page_problems``: every page the report saves
during a test is checked for text beyond the page and overlapping tick labels.
"""

import pytest

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
rasc_cli = shared.rasc_cli


def _page_problems(fig) -> list[str]:
    """What a reader could not read on a page: text reaching beyond the page (a line or
    label cut off), tick labels of one axis drawn over each other. 3-D axes are left out
    (their texts' extents are not where they are drawn), and so are ticks outside an
    axis's limits (not drawn)."""
    from matplotlib.text import Text
    from mpl_toolkits.mplot3d import Axes3D

    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    skip, problems = set(), []
    for ax in fig.axes:
        if isinstance(ax, Axes3D):
            skip |= {id(t) for t in ax.findobj(Text)}
            continue
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            shown = []
            for tick in axis.get_major_ticks():
                if lo - 1e-9 * (hi - lo) <= tick.get_loc() <= hi + 1e-9 * (hi - lo):
                    if tick.label1.get_visible() and tick.label1.get_text():
                        shown.append(tick.label1.get_window_extent(renderer))
                else:
                    skip |= {id(tick.label1), id(tick.label2)}
            shown.sort(key=lambda b: (b.x0, b.y0))
            if any(a.overlaps(b) for a, b in zip(shown, shown[1:], strict=False)):
                problems.append(f"tick labels overlap ({ax.get_title()!r})")
    page = fig.bbox
    for t in fig.findobj(Text):
        if t.get_visible() and t.get_text().strip() and id(t) not in skip:
            b = t.get_window_extent(renderer)
            if b.x0 < -1 or b.y0 < -1 or b.x1 > page.width + 1 or b.y1 > page.height + 1:
                problems.append(f"text beyond the page: {t.get_text()[:50]!r}")
    return problems


@pytest.fixture
def page_problems(monkeypatch) -> list[str]:
    """Each page the report saves while a test runs is checked first
    (:func:`_page_problems`); the list of what was found, per page."""
    from matplotlib.backends.backend_pdf import PdfPages

    found: list[str] = []
    save = PdfPages.savefig

    def checked(self, figure=None, **kwargs):
        found.extend(_page_problems(figure))
        return save(self, figure, **kwargs)

    monkeypatch.setattr(PdfPages, "savefig", checked)
    return found
