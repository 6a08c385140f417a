import pytest

from refsoft.conformance.golden import write_golden


@pytest.fixture(scope="session")
def golden(tmp_path_factory):
    """The whole golden set, every canonical case (about a minute), shared by the test files
    that do not write a smaller one of their own."""
    out = tmp_path_factory.mktemp("golden_all")
    write_golden(out)
    return out
