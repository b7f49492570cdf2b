"""The library never imports Jupyter; the widgets import the library, not the reverse."""

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
JUPYTER = {"ipywidgets", "ipycanvas", "IPython", "ipykernel", "jupyterlab", "traitlets", "comm"}


def test_importing_the_whole_library_loads_no_jupyter_module():
    code = f"""
import importlib, pkgutil, sys
import fluidnb

def walk(package):
    # Not pkgutil.walk_packages: it imports every subpackage, fluidnb.widgets included.
    for mod in pkgutil.iter_modules(package.__path__, package.__name__ + "."):
        if mod.name in ("fluidnb.widgets", "fluidnb.__main__"):
            continue
        module = importlib.import_module(mod.name)
        if mod.ispkg:
            walk(module)

walk(fluidnb)
assert "fluidnb.fields._advect" in sys.modules and "fluidnb.cli._info" in sys.modules
bad = sorted(m for m in sys.modules if m.split(".")[0] in {sorted(JUPYTER)!r})
print(",".join(bad))
"""
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    assert out.stdout.strip() == "", f"the library imported: {out.stdout}"


def test_library_source_has_no_jupyter_imports():
    offenders = []
    for path in (ROOT / "fluidnb").rglob("*.py"):
        if "widgets" in path.relative_to(ROOT / "fluidnb").parts:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            elif isinstance(node, ast.ImportFrom) and node.level and node.module:
                names = [node.module] if node.module.startswith("widgets") else []
            offenders += [f"{path}: {n}" for n in names if n.split(".")[0] in JUPYTER]
            offenders += [f"{path}: {n}" for n in names if n.startswith("fluidnb.widgets")]
    assert offenders == []


VIDEODB = ROOT / "fluidnb" / "videodb"
#: What each stage of fluidnb.videodb may not import: data flows database -> assignment
#: -> rendering; the starter databases and the lessons' figures sit above all three,
#: and what the stages share (_common) below them.
FORBIDDEN = {
    "database": {"assignment", "rendering", "starter", "figures"},
    "assignment": {"rendering", "starter", "figures"},
    "rendering": {"starter", "figures"},
    "_common": {"database", "assignment", "rendering", "starter", "figures"},
}


def _module_name(path, root):
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def package_imports(folder, root=ROOT):
    """Every module under ``folder`` -> the modules under ``folder`` it imports.

    Every import statement counts, those inside functions too: a function-level
    import is an import circle all the same, only hidden until the function runs.
    ``from package import name`` counts the submodule ``package.name`` when there is
    one, else the package (its ``__init__``).
    """
    modules = {_module_name(p, root): p for p in folder.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        found = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    found.add(sub if sub in modules else target)
            elif isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names)
        graph[name] = {m for m in found if m in modules and m != name}
    return graph


def circles(graph):
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def upward_imports(graph):
    """``"module imports target"`` for every import a stage may not make (FORBIDDEN)."""

    def stage(module):  # fluidnb.videodb.<stage>[.<module>]
        parts = module.split(".")
        return parts[2] if len(parts) > 2 else None

    return [
        f"{module} imports {target}"
        for module, targets in sorted(graph.items())
        for target in sorted(targets)
        if stage(target) in FORBIDDEN.get(stage(module), ())
    ]


def test_videodb_has_no_import_circle():
    graph = package_imports(VIDEODB)
    assert len(graph) > 40  # every module was read
    assert "fluidnb.videodb.database._format" in graph["fluidnb.videodb.database._frames"]
    assert circles(graph) == []


def test_videodb_stages_import_only_the_stages_below_them():
    assert upward_imports(package_imports(VIDEODB)) == []


def test_the_layering_checks_see_hidden_circles_and_upward_imports(tmp_path):
    # The checks on a made-up fluidnb/videodb: the database's store builds a frame
    # cache whose module imports the store back inside a function (the circle the
    # issue found), and the database imports the rendering inside a function.
    folder = tmp_path / "fluidnb" / "videodb"
    files = {
        "__init__.py": "from .database import _store\n",
        "database/__init__.py": "",
        "database/_store.py": "from ._frames import FrameCache\n",
        "database/_frames.py": (
            "class FrameCache:\n    pass\n\n"
            "def rebuild():\n"
            "    from ._store import read_rows\n"
            "    from ..rendering._blend import difference_frames\n"
        ),
        "rendering/__init__.py": "",
        "rendering/_blend.py": "",
        "rendering/_render.py": "from ..database import _store\n",
    }
    for name, text in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    graph = package_imports(folder, tmp_path)
    assert circles(graph) == [
        ["fluidnb.videodb.database._frames", "fluidnb.videodb.database._store"]
    ]
    assert upward_imports(graph) == [
        "fluidnb.videodb.database._frames imports fluidnb.videodb.rendering._blend"
    ]
    # "from package import module" is an import of the module
    assert graph["fluidnb.videodb.rendering._render"] == {"fluidnb.videodb.database._store"}


def test_widgets_ship_inside_the_package():
    import fluidnb.widgets

    link = ROOT / "fluidnb" / "widgets"
    assert link.is_symlink()
    assert link.resolve() == (ROOT / "widgets").resolve()
    assert Path(fluidnb.widgets.__file__).resolve().parent == (ROOT / "widgets").resolve()
