"""Imports run one way: the pipeline's early stages (the scene, the rasterizer, the searches)
never import the stages built on them (the frame driver, the truth, the conformance checks, the
benchmarks, the viewer, the command line), not even inside a function. The exceptions are the
replays of a whole frame (``ldt/trace.py``'s ``trace_pixel`` and ``search/trace.py``'s
``trace_vertex_bounce`` render the frame they replay through the frame driver): drivers
themselves, named here."""

import ast
import pathlib

import pytest

import refsoft

ROOT = pathlib.Path(refsoft.__file__).parent
EARLY = ("scene", "raster", "search", "ldt", "envmap")
LATE = {"frame", "truth", "conformance", "bench", "viewer", "cli"}
#: Modules that drive a whole frame, and what they may import of the later stages.
DRIVERS = {"ldt/trace.py": {"frame"}, "search/trace.py": {"frame"}}


def _imported_packages(path):
    """The refsoft subpackages a module imports (absolute or relative, at any depth)."""
    tree = ast.parse(path.read_text(), str(path))
    here = path.relative_to(ROOT).parts[:-1]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(here[:len(here) - (node.level - 1)]) if node.level > 1 else list(here)
                parts = base + (node.module.split(".") if node.module else [])
                names = [parts + [a.name] for a in node.names] if not node.module else [parts]
            elif node.module and node.module.split(".")[0] == "refsoft":
                names = [node.module.split(".")[1:]]
            else:
                continue
            found.update(p[0] for p in names if p)
        elif isinstance(node, ast.Import):
            found.update(a.name.split(".")[1] for a in node.names if a.name.startswith("refsoft."))
    return found


@pytest.mark.parametrize("package", EARLY)
def test_early_stages_do_not_import_later_ones(package):
    offenders = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        bad = _imported_packages(path) & LATE - DRIVERS.get(path.relative_to(ROOT).as_posix(), set())
        if bad:
            offenders[str(path.relative_to(ROOT))] = sorted(bad)
    assert not offenders, f"imports against the pipeline's direction: {offenders}"


def test_the_check_sees_an_import_inside_a_function(tmp_path):
    (tmp_path / "search").mkdir()
    module = tmp_path / "search" / "m.py"
    module.write_text("def f():\n    from ..truth.raytrace import primary_rays\n    return primary_rays\n")
    global ROOT
    saved, ROOT = ROOT, tmp_path
    try:
        assert _imported_packages(module) == {"truth"}
    finally:
        ROOT = saved
