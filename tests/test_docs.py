"""Every public callable documents itself (issue 8 §6)."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import tmaplan


def _public_modules():
    for info in pkgutil.walk_packages(tmaplan.__path__, "tmaplan."):
        name = info.name
        if any(part.startswith("_") for part in name.split(".")[1:]):
            continue
        yield importlib.import_module(name)


def test_every_public_callable_has_a_docstring():
    missing = []
    for mod in _public_modules():
        assert mod.__doc__ and mod.__doc__.strip(), f"module {mod.__name__}"
        for name in getattr(mod, "__all__", []):
            obj = getattr(mod, name)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue  # constants and type aliases
            if not (inspect.getdoc(obj) or "").strip():
                missing.append(f"{mod.__name__}.{name}")
            if inspect.isclass(obj):
                for meth_name, meth in vars(obj).items():
                    if meth_name.startswith("_") or not callable(meth):
                        continue
                    if not (inspect.getdoc(meth) or "").strip():
                        missing.append(f"{mod.__name__}.{name}.{meth_name}")
    assert not missing, "no docstring: " + ", ".join(sorted(set(missing)))


def test_every_public_module_declares_all():
    lacking = [m.__name__ for m in _public_modules()
               if not hasattr(m, "__all__") and not m.__name__.startswith("tmaplan.cli")]
    assert not lacking, lacking
