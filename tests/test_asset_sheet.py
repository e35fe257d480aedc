"""Contact sheets of asset variants and the category table: the same bytes for the same
arguments (in this process and another), the asked pixel size, a picture that is not
blank, labels that say each variant's id and size, one-line errors for bad arguments,
and a table of every category whose measured sizes keep to the declared ranges."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from citygen.assets import CATEGORIES, categories, resolve
from citygen.assets.category import ANCHORS
from citygen.errors import ExportError
from citygen.exporters import sheet
from citygen.spec.surfaces import ZONE_KINDS
from tests.conftest import ROOT

RENDER = """
import sys
from citygen.exporters.sheet import contact_sheet
contact_sheet("mailbox", sys.argv[1], count=4, start=7, size_px=400)
"""


def _pixels(path) -> np.ndarray:
    with Image.open(path) as im:
        assert im.format == "PNG"
        return np.asarray(im.convert("RGB"))


@pytest.fixture(scope="module")
def mailbox_sheet(tmp_path_factory) -> bytes:
    path = tmp_path_factory.mktemp("sheet") / "mailbox.png"
    assert sheet.contact_sheet("mailbox", path, count=4, start=7, size_px=400) == path
    return path.read_bytes()


def test_same_arguments_same_bytes(mailbox_sheet: bytes, tmp_path) -> None:
    again = sheet.contact_sheet("mailbox", tmp_path / "again.png", count=4, start=7, size_px=400)
    assert again.read_bytes() == mailbox_sheet
    # ... in another process too, whatever its hash seed
    other = tmp_path / "other.png"
    env = {**os.environ, "PYTHONHASHSEED": "4321", "PYTHONPATH": str(ROOT)}
    subprocess.run([sys.executable, "-c", RENDER, str(other)], env=env, check=True, capture_output=True)
    assert other.read_bytes() == mailbox_sheet
    assert b"matplotlib" not in mailbox_sheet.lower()  # no version or time written
    assert not list(tmp_path.glob(".*.tmp"))  # written through a temporary file and renamed


def test_sheet_size_and_content(mailbox_sheet: bytes, tmp_path) -> None:
    path = tmp_path / "m.png"
    path.write_bytes(mailbox_sheet)
    img = _pixels(path)
    assert img.shape == (400, 400, 3)  # 4 variants: 2 x 2 square cells
    colours = np.unique(img.reshape(-1, 3), axis=0)
    assert len(colours) >= 20  # shaded faces, labels, ground: far from blank
    not_white = (img < 235).any(axis=2)
    assert 0.03 < not_white.mean() < 0.8
    # every cell has something drawn in it
    for rows in (slice(0, 200), slice(200, 400)):
        for cols in (slice(0, 200), slice(200, 400)):
            assert not_white[rows, cols].mean() > 0.01


def test_rows_follow_the_count(tmp_path) -> None:
    path = sheet.contact_sheet("street_sign", tmp_path / "two.png", count=2, size_px=300)
    assert _pixels(path).shape == (150, 300, 3)  # 2 columns, 1 row


def test_labels_give_id_and_size() -> None:
    fig = sheet.sheet_figure("parking_meter", count=3, start=40, size_px=300)
    assert len(fig.axes) == 3 and fig.canvas.get_width_height() == (300, 300)
    labels = [t.get_text() for t in fig.texts]
    for v, label in zip((40, 41, 42), labels, strict=True):
        asset = resolve(f"parking_meter/{v:04d}")
        x0, y0, x1, y1 = asset.footprint.bounds
        assert label == f"parking_meter/{v:04d}\n{asset.height:.2f} x {y1 - y0:.2f} x {x1 - x0:.2f} m"


def test_unknown_category_lists_the_known_ones(tmp_path) -> None:
    with pytest.raises(ValueError, match="unknown asset category 'lamppost'") as caught:
        sheet.contact_sheet("lamppost", tmp_path / "x.png")
    message = str(caught.value)
    assert all(name in message for name in categories())
    assert isinstance(caught.value, ExportError) and "\n" not in message
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize(
    ("options", "field"),
    [
        ({"count": 0}, "count"),
        ({"count": 101}, "count"),
        ({"count": 2.0}, "count"),
        ({"start": -1}, "start"),
        ({"start": 9999, "count": 2}, "start + count"),
        ({"size_px": 10}, "size_px"),
        ({"size_px": True}, "size_px"),
    ],
)
def test_bad_arguments_name_the_field(options: dict, field: str, tmp_path) -> None:
    with pytest.raises(sheet.SheetError, match=f"^{re.escape(field)}: expected"):
        sheet.contact_sheet("bench", tmp_path / "x.png", **options)


def test_path_must_be_png(tmp_path) -> None:
    with pytest.raises(ValueError, match=r"expected a path ending in \.png"):
        sheet.contact_sheet("bench", tmp_path / "x.jpg", count=1)


def test_list_categories_covers_the_catalog_within_declared_ranges() -> None:
    rows = sheet.list_categories()
    assert [r["name"] for r in rows] == list(categories())
    for row in rows:
        entry = CATEGORIES[row["name"]]
        assert row["semantic_class"] == entry.semantic_class
        assert row["zones"] == sorted(entry.zones) and set(row["zones"]) <= set(ZONE_KINDS)
        assert row["anchor"] == entry.anchor and row["anchor"] in ANCHORS
        assert row["clearance"] == entry.clearance
        assert row["variants"] == 10_000
        for name in ("height", "size_x", "size_y"):
            low, high = row[name]
            declared = getattr(entry, name)
            assert declared[0] <= low <= high <= declared[1], (row["name"], name, row[name], declared)
    # the measured range holds the variants it was measured over
    bench = next(r for r in rows if r["name"] == "bench")
    heights = [resolve(f"bench/{v:04d}").height for v in range(100)]
    assert bench["height"] == (round(min(heights), 3), round(max(heights), 3))


def test_list_categories_rejects_bad_samples() -> None:
    with pytest.raises(ValueError, match="samples: expected"):
        sheet.list_categories(samples=0)
