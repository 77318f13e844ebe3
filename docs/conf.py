"""Sphinx configuration of the rangefx documentation site.

Build (from the repository root, with the ``docs`` extra installed)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The pages are Markdown (MyST); the API reference is autodoc + napoleon over the
numpy-style docstrings, the CLI reference sphinx-argparse over the parser that
``rangefx`` itself uses (:func:`rangefx.tools.cli.main.build_parser`).
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path

from docutils import nodes

REPO = Path(__file__).resolve().parent.parent
# cli.md's argparse directive imports this file as ``conf`` for :func:`cli_parser`
sys.path.insert(0, str(Path(__file__).resolve().parent))

# Plots in docstrings and the CLI import matplotlib: never open a window while building.
os.environ.setdefault("MPLBACKEND", "Agg")

project = "rangefx"
author = "rangefx developers"
copyright = "rangefx developers"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinxarg.ext",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]

html_theme = "furo"
html_title = "rangefx"
html_static_path = ["_static"]

# `#anchor` links to headings of other pages (`p1_datapath.md#speed-...`) and `$...$`
# math are used by the pages.
myst_heading_anchors = 4
myst_enable_extensions = ["dollarmath"]

# Document each object once, where it is defined: a package's ``__all__`` re-exports names
# of its modules, which would otherwise be described twice (ambiguous cross-references).
autodoc_default_options = {"members": True, "show-inheritance": False, "ignore-module-all": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_google_docstring = False
napoleon_numpy_docstring = True


RST_SPECIAL = re.compile(r"([\\*|`_])")


def _escape(text: str | None) -> str | None:
    return None if text is None else RST_SPECIAL.sub(r"\\\1", text)


def cli_parser() -> argparse.ArgumentParser:
    """The parser of ``rangefx`` (:func:`rangefx.tools.cli.main.build_parser`) with its help
    texts escaped for reStructuredText.

    argparse help is plain text, but sphinx-argparse parses it as reStructuredText, where
    ``min |h dE_M/dt|`` is a substitution reference and ``budget*(1-M) ... (1-agreement)*``
    emphasis. Escaping ``\\ * | ` _`` shows every help text as ``rangefx --help`` prints
    it; nothing else changes."""
    from rangefx.tools.cli.main import build_parser

    def escape_all(parser: argparse.ArgumentParser) -> None:
        parser.description = _escape(parser.description)
        parser.epilog = _escape(parser.epilog)
        for action in parser._actions:
            action.help = _escape(action.help) if action.help != argparse.SUPPRESS else action.help
            for choice in getattr(action, "_choices_actions", ()):
                choice.help = _escape(choice.help)
            if isinstance(action.choices, dict):
                for sub in action.choices.values():
                    if isinstance(sub, argparse.ArgumentParser):
                        escape_all(sub)

    parser = build_parser()
    escape_all(parser)
    return parser


CODE_SPAN = re.compile(r"(``.*?``|`[^`]*`)")


def escape_bars(app, what, name, obj, options, lines: list[str]) -> None:
    """Show ``|x - y|`` in docstrings as the absolute value it means.

    The docstrings write absolute values with bars (``|fixed - golden|``), which
    reStructuredText reads as a substitution reference; rangefx's docstrings use no
    substitutions, line blocks or grid tables. Bars inside code spans and ``::`` literal
    blocks are left alone (they render verbatim)."""
    literal_indent = None
    for i, line in enumerate(lines):
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None:
            if not line.strip() or indent > literal_indent:
                continue
            literal_indent = None
        if line.rstrip().endswith("::"):
            literal_indent = indent
        if "|" in line:
            parts = CODE_SPAN.split(line)
            parts[::2] = [part.replace("|", "\\|") for part in parts[::2]]
            lines[i] = "".join(parts)


def repository_path_link(app, env, node, contnode):
    """Render a Markdown link to a file of the repository outside ``docs/`` as a code
    path.

    The pages link source files (``[rtl_model/p1/cost.py](../rtl_model/p1/cost.py)``)
    that are not part of the site. Such a link is a real file, so it stays readable on
    GitHub; on the site it becomes the path in code font (no dead link). A link whose
    target does not exist in the repository is left to Sphinx, which warns (and ``-W``
    fails the build): ``tests/test_docs.py`` checks those paths too.
    """
    if node.get("refdomain") not in (None, "") and node.get("reftype") != "myst":
        return None
    target = node.get("reftarget", "")
    if not target or "://" in target:
        return None
    path = target.split("#", 1)[0]
    if not path:
        return None
    here = (REPO / "docs" / node.get("refdoc", "index")).parent
    resolved = (here / path).resolve()
    if not resolved.exists() or REPO not in (resolved, *resolved.parents):
        return None
    shown = resolved.relative_to(REPO).as_posix() + ("/" if resolved.is_dir() else "")
    text = contnode.astext()
    if text and text != shown and text != path:
        return nodes.inline("", "", nodes.Text(text + " ("), nodes.literal(shown, shown),
                            nodes.Text(")"))  # fmt: skip
    return nodes.literal(shown, shown)


#: The API reference: one page per package, listing every public module under it (the
#: CLI's own modules are documented by the CLI reference, from the parser).
API_PACKAGES = {
    "rangefx.api": "The Python API of the three jobs: cases, run, test vectors, replay, "
    "sweep, optimise, evaluate, guide.",
    "rangefx": "The package: numba's cache and CPU settings; the API's names, lazily.",
    "rangefx.golden": "Float64 reference of every algorithm of the report (SPEC §3).",
    "rangefx.rtl_model": "The bit-accurate, cycle-faithful pipelines and their interface.",
    "rangefx.vectors": "Test vectors, their files and manifest, the HDL replay.",
    "rangefx.guidance": "Chapter 6: the guidance law, obstacles, the simulation.",
    "rangefx.tools.studies": "Cases, the runner, sweeps, the optimiser, the benchmark.",
    "rangefx.tools.report": "Tables, plots and rangefx's output directories.",
}
API_SKIP = ("rangefx.tools.cli",)
API_DIR = Path(__file__).resolve().parent / "api" / "generated"


def public_modules(package: str) -> list[str]:
    """``package`` and its modules and subpackages, without private (``_``) names; the
    top package alone for ``rangefx`` (its subpackages have their own pages)."""
    import importlib
    import pkgutil

    mod = importlib.import_module(package)
    names = [package]
    if package == "rangefx" or not hasattr(mod, "__path__"):
        return names + (["rangefx.numba_cache"] if package == "rangefx" else [])
    for info in pkgutil.walk_packages(mod.__path__, prefix=package + "."):
        leaf = info.name.rsplit(".", 1)[1]
        if leaf.startswith("_") or info.name.startswith(API_SKIP):
            continue
        names.append(info.name)
    return names


def write_api_pages(app) -> None:
    """Write one reStructuredText page per package of :data:`API_PACKAGES` into
    ``api/generated/`` (not committed), so that a module added, moved or removed is
    documented without editing a page by hand. reStructuredText, not Markdown: autodoc
    emits reStructuredText, which a MyST page would read as Markdown."""
    API_DIR.mkdir(parents=True, exist_ok=True)
    wanted = set()
    for order, (package, summary) in enumerate(API_PACKAGES.items()):
        name = f"{order:02d}_{package.replace('.', '_')}.rst"
        wanted.add(name)
        # no ``.. contents::``: furo shows the page's contents beside it
        parts = [f"{package}\n{'=' * len(package)}\n\n{summary}\n"]
        for module in public_modules(package):
            # the package's own module sits under the page's title (no second heading)
            heading = "" if module == package else f"{module}\n{'-' * len(module)}\n\n"
            parts.append(f"\n{heading}.. automodule:: {module}\n")
        text = "".join(parts)
        page = API_DIR / name
        if not page.exists() or page.read_text() != text:
            page.write_text(text)
    for stale in API_DIR.glob("*"):
        if stale.name not in wanted:
            stale.unlink()


def setup(app):
    app.connect("builder-inited", write_api_pages)
    app.connect("autodoc-process-docstring", escape_bars)
    app.connect("missing-reference", repository_path_link)
