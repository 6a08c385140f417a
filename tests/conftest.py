import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def golden_set(tmp_path_factory):
    """The whole golden set, every canonical case (about a minute), written once per session and
    shared by the conformance tests and the GLSL port's."""
    from refsoft.conformance.golden import write_golden

    out = tmp_path_factory.mktemp("golden_all")
    write_golden(out)
    return out


_children = []


def pytest_collection_modifyitems(session, config, items):
    """Start the bounds-checked child run (``test_boundscheck.py``) as soon as its test is
    collected: it compiles on one core while the suite runs, instead of after it."""
    for item in items:
        if item.name == "test_subset_passes_with_numba_boundscheck":
            _children.append(item.module.start())
            break


def pytest_sessionfinish(session, exitstatus):
    for child in _children:
        child.close()
