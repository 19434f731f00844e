"""Figure helpers: the PNG check the tool tests share, and the plot modules' small rules."""

import numpy as np
import pytest
from matplotlib.image import imread

from sail_ros.plots.histories import equal_groups
from sail_ros.plots.sail3d import exaggeration_for, true_box_height

pytestmark = pytest.mark.model

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def assert_png(path, min_width=400, min_height=250):
    """A real PNG of page-figure size whose pixels are not one flat colour and
    not (almost) all background."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE, f"{path} is not a PNG"
    assert len(data) > 10_000, f"{path} is suspiciously small ({len(data)} bytes)"
    pixels = imread(path)[..., :3]
    height, width = pixels.shape[:2]
    assert width >= min_width and height >= min_height, f"{path}: {width}x{height} px"
    assert pixels.std() > 0.05, f"{path} is (nearly) blank"
    drawn = np.mean(np.any(pixels < 0.9, axis=-1))  # not white background
    assert drawn > 0.03, f"{path}: only {drawn:.1%} of the pixels are drawn"


def test_assert_png_rejects_a_blank_figure(tmp_path):
    from sail_ros.plots.common import figure, save

    fig, ax = figure(6.0, 4.0)
    ax.set_axis_off()
    path = save(fig, tmp_path / "blank.png")
    with pytest.raises(AssertionError, match="blank|drawn|small"):
        assert_png(path)


@pytest.mark.parametrize(
    ("height", "extent", "expected"),
    [
        (0.1, 15.0, 50.0),  # 0.35 * 15 / 0.1 = 52.5 -> 50
        (1.0, 70.0, 20.0),  # 24.5 -> 20
        (0.01, 10.0, 200.0),  # 350 -> 200
    ],
    ids=["deploy", "full-size", "tiny"],
)
def test_exaggeration_is_a_round_number_below_the_target(height, extent, expected):
    assert exaggeration_for(height, extent, fraction=0.35) == expected


def test_true_box_height_draws_the_stated_exaggeration():
    # 0.1 m drawn 50x over a 2 x 15 m plane: 5 m of 30 m, and the z range is +-0.1 m
    assert true_box_height(0.1, 15.0, 50.0) == pytest.approx(2 * 5.0 / 30.0)


def test_equal_groups_merge_identical_series_only():
    t = np.linspace(0, 1, 50)
    columns = np.column_stack([np.sin(t), np.cos(t), np.sin(t), np.cos(t) + 1e-3])
    assert equal_groups(columns) == [[0, 2], [1], [3]]
