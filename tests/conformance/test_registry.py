"""The rule modules of ``refsoft check`` and their registry: every kind is judged by a module,
every module has the interface, and the conformance package's imports go one way (no circles,
counting the imports inside functions)."""

import ast
from pathlib import Path

import pytest

from refsoft import constants
from refsoft.conformance import registry

PACKAGE = Path(registry.__file__).resolve().parent


def test_the_modules_judge_exactly_the_kinds_check_lists():
    assert set(registry.OWNED) == set(constants.CHECK_KINDS) and len(set(constants.CHECK_KINDS)) == len(
        constants.CHECK_KINDS)
    for module in registry.RULES:
        assert module.KINDS and callable(module.kind_of) and callable(module.judge), module.__name__


@pytest.mark.parametrize("key, kind", [("gbuffer_mask_1", "coverage"), ("gbuffer_depth_margin_3", "gbuffer"),
                                       ("reflection_pixel_2", "pixel"), ("virtual_vertex_1", "virtual"),
                                       ("traces_1", "trace"), ("image", "image"), ("reflected_id", "ids"),
                                       ("ldt_face", "ldt_pixel"), ("ldt_margin", "margin"), ("margin_1", "margin"),
                                       ("ldt_2.depth", "ldt_texture"), ("envmap_id_1", "envmap_cube"),
                                       ("ldt_region_1", "ldt_region"), ("*", "frame"), ("something_else", "other")])
def test_every_key_has_one_kind(key, kind):
    assert registry.output_kind(key) == kind


def test_a_comparison_method_claims_reflected_id_in_its_frames():
    assert registry.claims({"reflected_id": 0, "ldt_face": 0})["reflected_id"][1] == "ldt_pixel"
    assert registry.claims({"reflected_id": 0, "envmap_face": 0})["reflected_id"][1] == "envmap_pixel"
    assert registry.claims({"reflected_id": 0, "image": 0})["reflected_id"][1] == "ids"
    assert "gbuffer_depth_margin_1" not in registry.claims({"gbuffer_depth_margin_1": 0})  # the oracle's own


def _imports(path):
    """The modules of the conformance package a file imports, anywhere in it."""
    name = path.relative_to(PACKAGE).with_suffix("")
    parts = ["refsoft", "conformance", *name.parts]
    if parts[-1] == "__init__":
        parts = parts[:-1]
    package = parts if path.name == "__init__.py" else parts[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            target = base + (node.module.split(".") if node.module else [])
            if node.level == 0:
                target = node.module.split(".")
            for alias in node.names:
                for cand in (target + [alias.name], target):
                    if cand[:2] == ["refsoft", "conformance"] and _exists(cand):
                        out.add(".".join(cand))
                        break
    out.discard(".".join(parts))
    return out


def _exists(parts):
    rel = Path(*parts[2:]) if len(parts) > 2 else Path()
    return (PACKAGE / rel).with_suffix(".py").is_file() or (PACKAGE / rel / "__init__.py").is_file()


def test_the_conformance_package_imports_one_way():
    graph = {}
    for path in PACKAGE.rglob("*.py"):
        name = ".".join(["refsoft", "conformance", *path.relative_to(PACKAGE).with_suffix("").parts])
        graph[name.removesuffix(".__init__")] = _imports(path)
    assert "refsoft.conformance.rules.search" in graph["refsoft.conformance.registry"]
    state = {}

    def visit(node, path):
        state[node] = "open"
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                raise AssertionError("import circle: " + " -> ".join(path + [nxt]))
            if nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
