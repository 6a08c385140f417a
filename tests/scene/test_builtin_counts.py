"""``refsoft scenes`` lists the built-in scenes from a table: each row is what building the
scene gives."""

import pytest

from refsoft.scene import BUILTIN_SCENES
from refsoft.scene.builtin.counts import BUILTIN_COUNTS, measured_counts


def test_the_table_lists_every_builtin_scene():
    assert list(BUILTIN_COUNTS) == list(BUILTIN_SCENES)


@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_the_table_row_is_what_building_the_scene_gives(name):
    assert BUILTIN_COUNTS[name] == measured_counts(name)
