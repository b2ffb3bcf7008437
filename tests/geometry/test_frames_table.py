"""rasc/geometry/frames.py, from which the documentation's frame tables are generated,
lists every parameter of the pan-tilt unit model (the worked gauge example is run by the
doc-example collector from docs/guide/concepts.md)."""

from __future__ import annotations

from dataclasses import fields

from rasc.geometry.frames import FRAMES, TRANSFORMS, UNIT_PARAMETERS
from rasc.geometry.kinematics import PanTiltUnit


def test_unit_parameters_are_the_model_s():
    names = {f.name for f in fields(PanTiltUnit)}
    listed = [p.name for p in UNIT_PARAMETERS]
    assert names <= set(listed)
    for extra in set(listed) - names:   # the derived ones are properties
        assert isinstance(getattr(PanTiltUnit, extra), property)


def test_every_row_is_filled_and_named_once():
    for table in (FRAMES, TRANSFORMS, UNIT_PARAMETERS):
        names = [row.name for row in table]
        assert len(names) == len(set(names))
        for row in table:
            assert all(str(v).strip() for v in vars(row).values()), row


def test_the_chain_names_frames_of_the_table():
    frames = {f.name for f in FRAMES}
    for t in TRANSFORMS:
        a, b = t.name.removeprefix("T_").split("_from_")[0], t.name.split("_from_")[1]
        a, b = a.rstrip("LR"), b.split("(")[0].rstrip("LR")
        assert {a, b} <= frames, t.name
