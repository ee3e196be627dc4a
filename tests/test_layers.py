"""The package's layering (SPEC §2, the team's style): kernels → tiles → components → hydro →
scenes → engine / gis → systems → command line. A module imports only from its own layer or
those below, at module level or inside a function; the one exception is listed with its reason.
Type-only imports (``if TYPE_CHECKING:``) name types and are not counted."""
from __future__ import annotations

import ast
from pathlib import Path

import riverflow
from riverflow.components.status import FlowStatus

LAYERS = {
    "_validate": 0, "_atomic": 0, "_extras": 0, "_memory": 0, "kernels": 0,
    "tiles": 1,
    "components": 2,
    "hydro": 3, "physics": 3,
    "scenes": 4,
    "engine": 5, "gis": 5, "web": 5, "images": 5,
    "systems": 6,
    "demo": 7, "__main__": 7, "__init__": 7,
}
ALLOWED = {
    # RiverWorld asks for the schedule's default systems when it is made with none (SPEC §3:
    # the world holds the ordered systems); the schedule, which composes the systems, sits
    # above the engine that runs them.
    ("riverflow.engine.world", "riverflow.systems.schedule"),
}
ROOT = Path(riverflow.__file__).parent


def _part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _imports(tree: ast.AST):
    """(module imported, line) of every import outside ``if TYPE_CHECKING:`` blocks."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            stack.extend(node.orelse)
            continue
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == "riverflow":
                yield from ((f"riverflow.{a.name}", node.lineno) for a in node.names)
            else:
                yield node.module, node.lineno
        elif isinstance(node, ast.Import):
            yield from ((a.name, node.lineno) for a in node.names)
        stack.extend(ast.iter_child_nodes(node))


def test_no_module_imports_from_a_layer_above_its_own():
    wrong = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).with_suffix("")
        module = ".".join(rel.parts).removesuffix(".__init__")
        layer = LAYERS[_part(module)]          # a new top-level part must be placed here
        for imported, line in _imports(ast.parse(path.read_text(), str(path))):
            if not imported.startswith("riverflow.") or imported == "riverflow.__version__":
                continue
            if LAYERS[_part(imported)] > layer and (module, imported) not in ALLOWED:
                wrong.append(f"{rel}.py:{line} imports {imported}")
    assert not wrong, "imports from a layer above:\n" + "\n".join(wrong)


def test_every_kernel_status_constant_is_the_enums():
    """Kernels keep their own copies of the flow statuses (they sit below the components that
    define the enum): each must be the enum's number."""
    from importlib import import_module

    checked = 0
    for path in sorted((ROOT / "kernels").glob("*.py")):
        kernel = import_module(f"riverflow.kernels.{path.stem}")
        for name, value in vars(kernel).items():
            if name.startswith("STATUS_") and name[7:] in FlowStatus.__members__:
                assert value == FlowStatus[name[7:]], f"kernels.{path.stem}.{name}"
                checked += 1
    assert checked >= 10
