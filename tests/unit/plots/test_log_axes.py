"""Log axes of the standard figures labelled in plain Unicode at the decades (no mathtext)."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from coopsat.plots.figures import _log_y, decade_label


@pytest.mark.parametrize("value, label", [(1e-3, "10⁻³"), (1.0, "10⁰"), (10.0, "10¹"), (1e-12, "10⁻¹²"), (1e15, "10¹⁵"),
                                          (2e-3, ""), (5.0, ""), (0.0, ""), (-1.0, "")])
def test_decade_label(value, label):
    assert decade_label(value) == label


def _drawn_labels(y):
    fig = Figure()
    ax = fig.subplots()
    ax.plot(np.arange(len(y)), y)
    _log_y(ax)
    fig.canvas.draw()
    return [t.get_text() for t in ax.get_yticklabels() if t.get_text()]


def test_a_span_of_decades_is_labelled_at_the_decades():
    labels = _drawn_labels(np.geomspace(3e-9, 40.0, 50))
    decades = {decade_label(10.0**k) for k in range(-15, 8)}  # tick labels beyond the view included
    assert len(labels) >= 3 and set(labels) <= decades  # every few decades, as the locator spaces them


def test_a_narrow_span_keeps_matplotlibs_labels():
    labels = _drawn_labels(np.linspace(145.0, 180.0, 50))
    assert labels and not any(label.startswith("10") and "$" not in label for label in labels)
