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


def test_widgets_ship_inside_the_package():
    import fluidnb.widgets

    link = ROOT / "fluidnb" / "widgets"
    assert link.is_symlink()
    assert link.resolve() == (ROOT / "widgets").resolve()
    assert Path(fluidnb.widgets.__file__).resolve().parent == (ROOT / "widgets").resolve()
