"""A public name is defined in one place (issue 39): no two modules of ``tmaplan`` export
different objects under one name (``tmaplan.io.Contact`` and ``tmaplan.scenario.Contact`` were
two classes; the recorded one is now :class:`tmaplan.io.RecordedContact`).

A package that re-exports a name of its modules, and the front door ``tmaplan`` that re-exports
the names a user starts from, export the same object: that is one definition. The check walks
the ``__all__`` of every module and package of ``tmaplan``, with a self-test on planted modules.
"""

from __future__ import annotations

import importlib
import pkgutil
import types
from collections.abc import Iterable

import tmaplan


def _modules() -> list[types.ModuleType]:
    names = ["tmaplan"] + [m.name for m in pkgutil.walk_packages(tmaplan.__path__, "tmaplan.")
                           if not m.name.endswith("__main__")]
    return [importlib.import_module(n) for n in names]


def _definition(obj: object) -> object:
    """What makes two exports one definition: a class or function is defined by its module and
    qualified name (a re-export is the same), any other object by its identity."""
    if isinstance(obj, type | types.FunctionType):
        return (obj.__module__, obj.__qualname__)
    return id(obj)


def duplicate_names(modules: Iterable[types.ModuleType]) -> dict[str, list[str]]:
    """Public names that two modules export as different objects: name → the exporting modules
    (``module.name``), sorted."""
    seen: dict[str, dict[object, list[str]]] = {}
    for mod in modules:
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            seen.setdefault(name, {}).setdefault(_definition(obj), []).append(mod.__name__)
    return {name: sorted(m for mods in defs.values() for m in mods)
            for name, defs in sorted(seen.items()) if len(defs) > 1}


def test_a_public_name_is_defined_in_one_place() -> None:
    dup = duplicate_names(_modules())
    assert not dup, "one name, several objects (rename one): " + "; ".join(
        f"{name}: {', '.join(mods)}" for name, mods in dup.items())


def _module(name: str, **attrs: object) -> types.ModuleType:
    mod = types.ModuleType(name)
    for key, value in attrs.items():
        setattr(mod, key, value)
    mod.__all__ = [k for k in attrs if not k.startswith("_")]  # type: ignore[attr-defined]
    return mod


def test_planted_duplicate_is_caught_and_a_re_export_is_not() -> None:
    contact_a = type("Contact", (), {"__module__": "fake.scenario"})
    contact_b = type("Contact", (), {"__module__": "fake.io"})
    limit = 3.5  # a constant re-exported is the same object
    scenario = _module("fake.scenario", Contact=contact_a, LIMIT=limit)
    io = _module("fake.io", Contact=contact_b)
    front = _module("fake", Contact=contact_a, LIMIT=limit)
    assert duplicate_names([scenario, front]) == {}
    assert duplicate_names([scenario, io, front]) == {
        "Contact": ["fake", "fake.io", "fake.scenario"]}
    # two constants of one name and different values are two definitions
    other = _module("fake.other", LIMIT=[1.0])
    assert list(duplicate_names([scenario, other])) == ["LIMIT"]
