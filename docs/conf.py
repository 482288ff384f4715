"""Sphinx configuration of the tomosim documentation.

Build it (the ``docs`` extra installs Sphinx and its extensions)::

    python -m pip install -e ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

and open ``docs/_build/html/index.html``.
"""

from __future__ import annotations

import inspect
import os
import re
import sys
import typing
from importlib.metadata import version as _version
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
# Plotting modules pick their backend at import; the build never opens a window.
os.environ.setdefault("MPLBACKEND", "Agg")

project = "tomosim"
author = "the tomosim authors"
copyright = "the tomosim authors"
release = _version("tomosim")
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
# Reports the scripts write are included by the benchmark pages, not built on their own.
exclude_patterns = ["_build", "_templates", "reproduce_paper.md", "figures/**.md"]
templates_path = ["_templates"]

# -- MyST ------------------------------------------------------------------------
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# -- API reference -----------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the numpydoc sections state types in words
autodoc_class_signature = "separated"

# envs.sb3 builds on Stable-Baselines3 (the rl extra), envs.rllib on RLlib and torch (the
# rllib extra); the reference needs only their names, so it builds without the extras.
autodoc_mock_imports = ["stable_baselines3", "ray", "torch"]

numpydoc_show_class_members = False  # the autodoc members stand under the class
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# Every cross-reference must resolve: the docstrings' :func: and :class: roles name
# this project's objects, and a wrong target fails the build.
nitpicky = True
# Other projects' objects are named, not linked (no intersphinx: the build needs no
# network), so references into them are not checked.
_EXTERNAL = (
    "argparse",
    "collections",
    "gymnasium",
    "matplotlib",
    "numba",
    "numpy",
    "pettingzoo",
    "pymunk",
    "ray",
    "rerun",
    "scipy",
    "skimage",
    "stable_baselines3",
    "supersuit",
    "torch",
    "typing",
)
# argparse's ArgumentParser.error documents its signature as ``error(message: string)``.
nitpick_ignore = [("py:class", "string")]
nitpick_ignore_regex = [(r"py:.*", rf"({'|'.join(_EXTERNAL)})(\..*)?")]

# -- HTML --------------------------------------------------------------------------
html_theme = "furo"
html_title = f"tomosim {release}"
html_static_path: list[str] = []


# -- One page per object -------------------------------------------------------------
# A class that a package re-exports is documented where it is defined and on the
# outermost package that exports it (``merging.FusedMap``); packages in between
# (``merging.linking``) list it without documenting it a third time, which would
# register its canonical name twice.
_documenting: list[str] = [""]


def _note_module(app, what, name, obj, options, lines):
    if what == "module":
        _documenting[0] = name


def _skip_documented_outside(app, what, name, obj, skip, options):
    if what != "module" or not isinstance(obj, type):
        return None
    here = _documenting[0]
    if getattr(obj, "__module__", here) == here:
        return None
    parts = here.split(".")
    for depth in range(1, len(parts)):
        outer = sys.modules.get(".".join(parts[:depth]))
        exported = getattr(outer, "__all__", ())
        if any(getattr(outer, export, None) is obj for export in exported):
            return True
    return None


def _skip_type_alias(app, what, name, obj, skip, options):
    # Sphinx 9.0 takes a subscripted alias (``Rect = tuple[float, ...]``) for a class and
    # fails to format its signature; the aliases are named in the signatures that use them.
    return True if typing.get_origin(obj) is tuple else None


# -- Names as the code reads them --------------------------------------------------
# Docstrings name objects the way their module's code does: ``:class:`World``` in a
# module that imports ``World``. Sphinx looks a short name up only in the module and
# class the docstring is rendered under, so a reference it cannot place is resolved
# here through the Python namespace of the module that wrote the docstring. An
# attribute that has no entry of its own (a dataclass field, described in its class's
# ``Attributes`` section) links to its class. A name that no namespace holds, or whose
# object is not documented, still fails the build.
_DOCSTRING_OF = re.compile(r"docstring of ([\w.]+)")


def _lookup(dotted):
    """The object a dotted name reaches from an importable module, or None."""
    parts = dotted.split(".")
    for depth in range(len(parts), 0, -1):
        module = sys.modules.get(".".join(parts[:depth]))
        if module is None:
            continue
        value = module
        for part in parts[depth:]:
            value = getattr(value, part, None)
            if value is None:
                return None
        return value
    return None


def _scopes(node):
    """Modules and classes whose names a reference's docstring sees, innermost first."""
    scopes = []
    found = _DOCSTRING_OF.search(str(node.source or ""))
    if found:
        documented = _lookup(found.group(1))
        function = getattr(documented, "fget", getattr(documented, "func", documented))
        home = getattr(function, "__module__", None)  # a property's, or a cached one's
        if isinstance(home, str):
            scopes.append(sys.modules.get(home))
        parts = found.group(1).split(".")
        scopes += [_lookup(".".join(parts[:depth])) for depth in range(len(parts), 0, -1)]
    if node.get("py:module"):
        module = node["py:module"]
        if node.get("py:class"):
            scopes.append(_lookup(f"{module}.{node['py:class']}"))
        scopes.append(sys.modules.get(module))
    return [scope for scope in scopes if inspect.ismodule(scope) or inspect.isclass(scope)]


def _has_attribute(cls, name):
    """Whether instances of ``cls`` have the attribute ``name`` (field, slot or property)."""
    annotated = any(name in vars(klass).get("__annotations__", {}) for klass in cls.__mro__)
    return annotated or hasattr(cls, name)


def _is_defined(value):
    """Whether ``value`` is a class or function that names where it is defined."""
    named = isinstance(getattr(value, "__qualname__", None), str)
    return named and (inspect.isclass(value) or inspect.isfunction(value))


def _defining_name(value, name, objects):
    """The documented full name of a module, class, function or constant, or None."""
    if inspect.ismodule(value):
        return value.__name__
    if _is_defined(value):
        return f"{value.__module__}.{value.__qualname__}"
    homes = [  # a constant: documented in the module that defines it
        full
        for full in objects
        if full.rsplit(".", 1)[-1] == name
        and getattr(sys.modules.get(full.rsplit(".", 1)[0]), name, object()) is value
    ]
    return homes[0] if len(homes) == 1 else None


def _walk(scope, path, objects):
    """The documented full name that ``path`` reaches from ``scope``, or None."""
    owner = _defining_name(scope, "", objects)
    value = scope
    for index, part in enumerate(path):
        last = index == len(path) - 1
        member = getattr(value, part, None)
        if inspect.ismodule(member) or _is_defined(member):
            owner, value = _defining_name(member, part, objects), member
        elif owner is not None and f"{owner}.{part}" in objects:
            owner, value = f"{owner}.{part}", member
        elif inspect.isclass(value) and last and _has_attribute(value, part):
            return owner  # a field, described in its class's Attributes section
        elif inspect.ismodule(value) and member is not None:
            owner, value = _defining_name(member, part, objects), member
        else:
            return None
        if owner is None:
            return None
    return owner if owner in objects else None


def _documented(target, scopes, objects):
    """The documented full name ``target`` means in ``scopes``, or None."""
    parts = target.split(".")
    starts = [(scope, parts) for scope in scopes]
    for depth in range(len(parts) - 1, 0, -1):  # a full dotted name
        module = sys.modules.get(".".join(parts[:depth]))
        if module is not None:
            starts.append((module, parts[depth:]))
            break
    for scope, path in starts:
        full = _walk(scope, path, objects)
        if full is not None:
            return full
    return None


def _resolve_as_code_reads(app, env, node, contnode):
    if node.get("refdomain") != "py":
        return None
    domain = env.domains["py"]
    full = _documented(node["reftarget"].lstrip(".~"), _scopes(node), domain.objects)
    if full is None:
        return None
    reftype = node["reftype"]
    if domain.objects[full].objtype == "class" and reftype in {"attr", "data"}:
        reftype = "class"  # a field described by its class
    return domain.resolve_xref(env, node["refdoc"], app.builder, reftype, full, node, contnode)


def setup(app):
    app.connect("autodoc-process-docstring", _note_module)
    app.connect("autodoc-skip-member", _skip_documented_outside)
    app.connect("autodoc-skip-member", _skip_type_alias)
    app.connect("missing-reference", _resolve_as_code_reads)
