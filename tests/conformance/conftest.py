import pytest


@pytest.fixture(scope="session")
def golden(golden_set):
    """The whole golden set (tests/conftest.py), shared by the test files that do not write a
    smaller one of their own."""
    return golden_set
