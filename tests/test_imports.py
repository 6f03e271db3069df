"""No import cycle inside the package (issue 11).

The test reads the source of every module of ``python/tilesynth`` with :mod:`ast` (nothing is imported) and
collects every ``from . import x`` / ``from .m import x`` / ``import tilesynth.m`` it finds, at module level
*and* inside functions: a deferred import only hides a cycle from the interpreter, it is still a cycle in the
design (the four-module cycle omega -> select -> omega, tilefile -> synthesis -> omega -> tilefile was made of
deferred imports). Two kinds are left out, each for a stated reason:

* imports under ``if TYPE_CHECKING:`` (annotations only, never executed);
* imports of the package root ``tilesynth`` itself: ``__init__`` is the facade that re-exports everything, so
  every module is "below" it by design (the package's own modules do not import it: the version lives in
  ``_version``).

The graph's strongly connected components (Tarjan) must all be single modules.

The second check is the *direction* of every import: the folders are layers, each allowed to use only the
layers below it (:data:`LAYERS`), so that a reader can follow a build downwards from ``cli`` to ``base``.
An import that reaches up, at module level or inside a function, fails the test, with three stated
exceptions: a few modules sit on another layer than their folder's (:data:`LAYER_OF_MODULE`, each a leaf
whose own imports are checked against the layer it is given), a few single upward uses are allowed by name
(:data:`ALLOWED_UPWARD`), and the lazy imports of heavy or optional third-party packages are named in one
place (:data:`LAZY_EXTERNAL`). Inside one layer there is no declared order: the graph itself is the order,
and the cycle check above keeps it one.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import tilesynth

PKG = "tilesynth"
ROOT = Path(tilesynth.__file__).resolve().parent

LAYERS: tuple[str, ...] = (
    "core",  # errors, _version, the native _core: no package imports
    "base",  # kernels over _core, validation, budgets, signals: no pipeline knowledge
    "io",  # reading and writing images and paths
    "layouts",  # the papers' sets, Wang sets, complete sets, the scan-line tiler, the hash lookup
    "tileset",  # the data model and its file
    "synth",  # laying a tile set out into a texture
    "measure",  # metrics, quality, diagnostics (they synthesize samples, so they sit above synth)
    "builder",  # the build stages: exemplar, recipe, genes, matching, cut, compose, smoothing
    "schemes",  # the registry of builders (omega, Wang, s-Wang, patch)
    "engine",  # engine export
    "cli",  # commands and batch
    "facade",  # the package root that re-exports everything
)
"""The layers, lowest first: a module may import its own layer and the layers before it."""

FOLDER_LAYER = {"errors": "core", "_version": "core", "_core": "core", "data": "base", "__main__": "cli"}
"""The layer of the package's top-level modules (the folders are their own layer)."""

LAYER_OF_MODULE: dict[str, tuple[str, str]] = {
    "tilesynth.cli.argtypes": (
        "base",
        "the value parsers (integers, floats, sizes, the normal-map Y convention) that the API's schemes and "
        "engine export check their arguments with as the CLI does; it imports nothing of the package but errors",
    ),
    "tilesynth.builder.smoothing": (
        "synth",
        "the Poisson smoothing of composed tiles, run by the builder's compose stage and again by synthesis "
        "when it lays out a material map's tiles; it imports only the kernels",
    ),
    "tilesynth.builder.matching.augment": (
        "synth",
        "the rotations and mirrors of matching patches, replayed by synthesis to read a material map's "
        "patches as the build transformed them; it imports only the kernels",
    ),
    "tilesynth.measure.report": (
        "schemes",
        "the HTML report is a consumer of every stage (it lays the material maps out through the builder), "
        "not a measure the builder uses: nothing below the CLI imports it",
    ),
}
"""Modules on another layer than their folder's, with the reason; their own imports are checked against it."""

ALLOWED_UPWARD: dict[tuple[str, str], str] = {
    ("tilesynth.tileset.tilefile", "tilesynth.synth.synthesis"): (
        "TileSet.synthesize, the public shorthand tiles.synthesize(w, h): one deferred call; the data model "
        "does not otherwise depend on synthesis, and synthesis refers to TileSet only in annotations"
    ),
}
"""Single upward imports allowed by name (importer, imported), with the reason."""

LAZY_EXTERNAL: dict[str, str] = {
    "numpy": "the CLI's path and batch planning modules stay importable without loading numpy",
    "PIL": "Pillow is loaded only for the formats the core does not decode (and for the report's fonts)",
    "distributed": "optional (the 'dask' extra): batch on a Dask cluster",
    "jsonschema": "optional: validating an engine manifest against its schema",
    "tomli": "only on Python < 3.11 (tomllib elsewhere)",
    "tomllib": "the standard library's TOML reader, chosen by version next to tomli",
}
"""Third-party (or version-dependent) packages a function may import lazily, with the reason. Other
function-level imports of a non-package module must be of the standard library."""


def _modules(root: Path) -> dict[str, Path]:
    out = {}
    for p in sorted(root.rglob("*.py")):
        parts = [PKG, *p.relative_to(root).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """ids of the import nodes inside ``if TYPE_CHECKING:`` blocks."""
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If):
            t = node.test
            name = t.id if isinstance(t, ast.Name) else t.attr if isinstance(t, ast.Attribute) else None
            if name == "TYPE_CHECKING":
                for inner in node.body:
                    skip.update(id(n) for n in ast.walk(inner))
    return skip


def _function_nodes(tree: ast.AST) -> set[int]:
    """ids of the nodes inside a function (or lambda) body: the imports that run at call time."""
    inner: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            for child in ast.iter_child_nodes(node):
                inner.update(id(n) for n in ast.walk(child))
    return inner


def imports(root: Path = ROOT) -> list[tuple[str, int, str, bool]]:
    """Every import of the package's modules outside ``if TYPE_CHECKING:``: ``(importer, line, imported,
    inside a function)``. ``imported`` is the package module it reaches (``tilesynth.x.y`` if that is a
    module, else its nearest package module; the native ``tilesynth._core`` counts as a module), or the
    top-level name of a module outside the package."""
    mods = set(_modules(root)) | {f"{PKG}._core"}
    out: list[tuple[str, int, str, bool]] = []
    for mod, path in _modules(root).items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        skip = _type_checking_nodes(tree)
        in_fn = _function_nodes(tree)
        package = mod.split(".") if path.name == "__init__.py" else mod.split(".")[:-1]
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            targets: list[str] = []
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package[: len(package) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    targets.append(sub if sub in mods else target)
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            for t in targets:
                if t != PKG and not t.startswith(PKG + "."):
                    out.append((mod, node.lineno, t.split(".")[0], id(node) in in_fn))
                    continue
                while t and t not in mods and "." in t:
                    t = t.rsplit(".", 1)[0]
                if t != mod:
                    out.append((mod, node.lineno, t, id(node) in in_fn))
    return out


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the package modules it imports (anywhere in its source, see the module docstring); the
    package root (the facade) and the native core are left out."""
    graph: dict[str, set[str]] = {m: set() for m in _modules(root)}
    for mod, _, t, _ in imports(root):
        if t in graph and t != PKG:
            graph[mod].add(t)
    return graph


def layer_of(mod: str) -> str:
    """The layer of a package module: :data:`LAYER_OF_MODULE`, else its folder's (:data:`FOLDER_LAYER` for
    the top-level modules), the package root being the facade."""
    if mod in LAYER_OF_MODULE:
        return LAYER_OF_MODULE[mod][0]
    parts = mod.split(".")
    if len(parts) == 1:
        return "facade"
    return FOLDER_LAYER.get(parts[1], parts[1])


def upward_imports(root: Path = ROOT) -> list[str]:
    """``"importer:line -> imported (layer -> layer)"`` for every import that reaches a higher layer and is
    not in :data:`ALLOWED_UPWARD`."""
    rank = {name: i for i, name in enumerate(LAYERS)}
    out = []
    for mod, line, t, _ in imports(root):
        if not t.startswith(PKG) or (mod, t) in ALLOWED_UPWARD:
            continue
        a, b = layer_of(mod), layer_of(t)
        if rank[b] > rank[a]:
            out.append(f"{mod}:{line} -> {t} ({a} -> {b})")
    return out


def lazy_external_imports(root: Path = ROOT) -> list[str]:
    """``"importer:line -> module"`` for every function-level import of a module outside the package that is
    neither in :data:`LAZY_EXTERNAL` nor in the standard library."""
    return [
        f"{mod}:{line} -> {t}"
        for mod, line, t, in_fn in imports(root)
        if in_fn and not t.startswith(PKG) and t not in LAZY_EXTERNAL and t not in sys.stdlib_module_names
    ]


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), plus self-loops."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in graph.get(v, ()):
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle_in_the_package():
    graph = import_graph()
    assert len(graph) > 20  # the walk found the package
    assert cycles(graph) == []


def test_every_module_has_a_layer():
    assert set(LAYERS) >= {layer_of(m) for m in import_graph()}
    assert all(layer in LAYERS for layer, _ in LAYER_OF_MODULE.values())


def test_no_import_reaches_up_the_layers():
    """Module level or inside a function: a lower layer never imports a higher one (see the docstring)."""
    assert upward_imports() == []


def test_lazy_third_party_imports_are_the_named_ones():
    assert lazy_external_imports() == []


def test_the_exceptions_are_still_needed():
    """Each exception is in use: an allowed upward import still exists; a module placed below its folder's
    layer is imported from a layer under its folder's, one placed above imports a layer above its folder's."""
    found = imports()
    assert set(ALLOWED_UPWARD) <= {(m, t) for m, _, t, _ in found}
    rank = {name: i for i, name in enumerate(LAYERS)}
    for mod, (layer, _) in LAYER_OF_MODULE.items():
        folder = rank[FOLDER_LAYER.get(mod.split(".")[1], mod.split(".")[1])]
        if rank[layer] < folder:
            assert any(t == mod and rank[layer_of(m)] < folder for m, _, t, _ in found), mod
        else:
            assert any(
                m == mod and rank[layer_of(t)] > folder for m, _, t, _ in found if t.startswith(PKG)
            ), mod


def test_the_checker_finds_a_cycle(tmp_path):
    """The checker itself: a deferred import that closes a loop is a cycle; a TYPE_CHECKING one is not."""
    pkg = tmp_path / PKG
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from .a import f\n")
    (pkg / "a.py").write_text("from .b import g\n\ndef f():\n    return g()\n")
    (pkg / "b.py").write_text("def g():\n    from .a import f\n    return f\n")
    (pkg / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .a import f\n")
    (pkg / "d.py").write_text("from . import c\n")
    graph = import_graph(pkg)
    assert graph[f"{PKG}.d"] == {f"{PKG}.c"}
    assert graph[f"{PKG}.c"] == set()
    assert cycles(graph) == [[f"{PKG}.a", f"{PKG}.b"]]


def test_the_checker_finds_an_upward_import(tmp_path, monkeypatch):
    """The checker itself: a deferred import of a higher layer is found (module level too), a lower one and a
    same-layer one are not, the native core is a module of the bottom layer, and an unnamed third-party lazy
    import is reported while a standard-library one is not."""
    pkg = tmp_path / PKG
    for folder in ("base", "builder", "cli"):
        (pkg / folder).mkdir(parents=True)
        (pkg / folder / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("from .cli.main import run\n")
    (pkg / "base" / "low.py").write_text(
        "from .. import _core\n\ndef f():\n    from ..builder.stage import g\n"
    )
    (pkg / "base" / "other.py").write_text("from ..cli.main import run\nimport json\n")
    (pkg / "builder" / "stage.py").write_text(
        "def g():\n    from ..base.low import f\n    from . import helper\n    import os\n    import scipy\n"
    )
    (pkg / "builder" / "helper.py").write_text("def h():\n    import numpy\n")
    (pkg / "cli" / "main.py").write_text("from ..builder.stage import g\n\ndef run():\n    return g\n")
    monkeypatch.setattr(sys.modules[__name__], "LAYER_OF_MODULE", {})
    monkeypatch.setattr(sys.modules[__name__], "ALLOWED_UPWARD", {})
    assert upward_imports(pkg) == [
        f"{PKG}.base.low:4 -> {PKG}.builder.stage (base -> builder)",
        f"{PKG}.base.other:1 -> {PKG}.cli.main (base -> cli)",
    ]
    assert (f"{PKG}.base.low", 1, f"{PKG}._core", False) in imports(pkg)
    assert lazy_external_imports(pkg) == [f"{PKG}.builder.stage:5 -> scipy"]
    monkeypatch.setattr(
        sys.modules[__name__], "ALLOWED_UPWARD", {(f"{PKG}.base.low", f"{PKG}.builder.stage"): ""}
    )
    monkeypatch.setattr(
        sys.modules[__name__], "LAYER_OF_MODULE", {f"{PKG}.base.other": ("cli", "a stated reason")}
    )
    assert upward_imports(pkg) == []
