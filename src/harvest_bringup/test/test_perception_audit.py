"""tools/perception_audit.py: its distance of each fruit to the nearest location and its labels."""

import pytest

from harvest_test_utils.tools import load_tool


@pytest.fixture()
def audit():
    return load_tool('perception_audit')


def test_each_fruit_gets_the_distance_to_the_nearest_location_or_none(audit):
    located = [(0.5, 0.1, 1.0), (0.5, 0.3, 1.0)]
    errors = audit.nearest_errors(located, [(0.5, 0.11, 1.0), (0.5, 0.3, 1.05)])
    assert errors == pytest.approx([0.01, 0.05])
    assert audit.nearest_errors([], [(0.5, 0.1, 1.0)]) == [None]
    assert audit.nearest_errors(located, []) == []


def test_a_pair_is_labelled_by_its_noise_frames_and_error_in_mm(audit):
    assert audit.pair_label(2, 0, 0.0124) == 'r2l0:12'
    assert audit.pair_label(3, 3, None) == 'r3l3:-'
