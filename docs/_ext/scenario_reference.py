"""Sphinx directive ``scenario-reference``: the scenario-file reference, generated.

Every TOML table and key of a scenario file, with its type, unit, constraint, default and
description, is read at build time from the frozen dataclasses of :mod:`tmaplan.scenario`
(field annotations and defaults) and their numpydoc ``Attributes`` sections, so the page cannot
drift from the code. A field without a description, or a unit dimension this module does not
know, fails the build.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import operator
import types
import typing
from collections.abc import Iterator
from typing import Any

from docutils import nodes
from docutils.statemachine import StringList
from numpydoc.docscrape import NumpyDocString
from sphinx.application import Sphinx
from sphinx.errors import ExtensionError
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

# SI unit of each dimension of tmaplan.units (checked against tmaplan.units at build time).
SI_UNITS = {
    "length": "m",
    "time": "s",
    "angle": "rad",
    "speed": "m/s",
    "angular_rate": "rad/s",
    "frequency": "Hz",
    "process_noise": "m^2/s^3",
    "dimensionless": "",
}
EXAMPLES = {
    "length": '``"3.5 km"``, ``"2 nmi"``',
    "time": '``"10 min"``',
    "angle": '``"45 deg"``',
    "speed": '``"12 kn"``',
    "angular_rate": '``"0.5 deg/s"``',
    "frequency": '``"3 kHz"``',
    "process_noise": '``"1e-3 m^2/s^3"``',
    "dimensionless": "",
}


def _check_units() -> None:
    from tmaplan.units import DIMENSIONS, to_si

    unknown = set(DIMENSIONS) - set(SI_UNITS)
    if unknown:
        raise ExtensionError(f"scenario_reference: no SI unit for dimensions {sorted(unknown)}")
    for dim, unit in SI_UNITS.items():
        if unit and to_si(f"1 {unit}", dim, "check") != 1.0:
            raise ExtensionError(f"scenario_reference: {unit!r} is not the SI unit of {dim}")


def _strip_optional(tp: Any) -> tuple[Any, bool]:
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) < len(typing.get_args(tp)):
            return (args[0] if len(args) == 1 else functools.reduce(operator.or_, args)), True
    return tp, False


def _dimension(metadata: tuple[Any, ...]) -> str | None:
    for m in metadata:
        func = getattr(m, "func", None)
        if func is not None:
            dim = inspect.getclosurevars(func).nonlocals.get("dimension")
            if dim is not None:
                return str(dim)
    return None


def _constraints(metadata: tuple[Any, ...]) -> list[str]:
    out = []
    for m in metadata:
        for item in [m, *getattr(m, "metadata", [])]:
            for attr, sym in (("gt", ">"), ("ge", "≥"), ("lt", "<"), ("le", "≤")):
                val = getattr(item, attr, None)
                if val is not None and type(item).__name__ != "FieldInfo":
                    out.append(f"{sym} {val}")
    return sorted(set(out))


def _dataclasses_in(tp: Any) -> list[type]:
    tp, _ = _strip_optional(tp)
    if typing.get_origin(tp) is typing.Annotated:
        return _dataclasses_in(typing.get_args(tp)[0])
    if dataclasses.is_dataclass(tp):
        return [tp]
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        return [c for a in typing.get_args(tp) for c in _dataclasses_in(a)]
    if typing.get_origin(tp) is tuple:
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return _dataclasses_in(args[0])
    return []


def describe_type(tp: Any) -> str:
    """Readable type of a scenario value: SI unit, constraints, accepted forms."""
    tp, _ = _strip_optional(tp)
    metadata: tuple[Any, ...] = ()
    if typing.get_origin(tp) is typing.Annotated:
        base, *meta = typing.get_args(tp)
        metadata = tuple(meta)
        tp = base
    origin = typing.get_origin(tp)
    if origin is typing.Literal:
        return "one of " + ", ".join(f'``"{v}"``' if isinstance(v, str) else f"``{v}``"
                                     for v in typing.get_args(tp))
    if origin is tuple:
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"array of ({describe_type(args[0])})"
        inner = {describe_type(a) for a in args}
        what = inner.pop() if len(inner) == 1 else "; ".join(describe_type(a) for a in args)
        return f"array of {len(args)} ({what})"
    if origin in (typing.Union, types.UnionType):
        return " or ".join(describe_type(a) for a in typing.get_args(tp))
    dim = _dimension(metadata)
    cons = _constraints(metadata)
    if dim is not None:
        unit = SI_UNITS[dim]
        text = f"{dim.replace('_', ' ')} [{unit}]" if unit else "number"
        if cons:
            text += ", " + ", ".join(cons)
        if unit:
            text += f"; a number in {unit} or a string with a unit, e.g. {EXAMPLES[dim]}"
        return text
    name = {float: "number", int: "integer", bool: "boolean", str: "string"}.get(
        tp, getattr(tp, "__name__", str(tp)))
    return name + (", " + ", ".join(cons) if cons else "")


def _default(field: dataclasses.Field[Any]) -> str:
    if field.default is not dataclasses.MISSING:
        value = field.default
    elif field.default_factory is not dataclasses.MISSING:
        value = field.default_factory()
    else:
        return "**required**"
    if value is None:
        return "not set"
    if isinstance(value, str):
        return f'``"{value}"``'
    if isinstance(value, tuple):
        return f"``{list(value)!r}``"
    if isinstance(value, bool):
        return f"``{str(value).lower()}``"
    return f"``{value!r}``"


def _field_docs(cls: type) -> tuple[str, dict[str, str]]:
    doc = NumpyDocString(inspect.getdoc(cls) or "")
    summary = "\n".join([*doc["Summary"], "", *doc["Extended Summary"]]).strip()
    fields: dict[str, str] = {}
    for p in doc["Attributes"]:
        text = " ".join(line.strip() for line in p.desc).strip()
        for name in (n.strip() for n in p.name.split(",")):
            fields[name] = text
    return summary, fields


def _tables(cls: type, header: str, array: bool) -> Iterator[tuple[str, type, bool]]:
    yield header, cls, array
    for f in dataclasses.fields(cls):
        hints = typing.get_type_hints(cls, include_extras=True)
        for sub in _dataclasses_in(hints[f.name]):
            tp, _ = _strip_optional(hints[f.name])
            is_array = typing.get_origin(tp) is tuple
            name = f"{header}.{f.name}" if header else f.name
            yield from _tables(sub, name, is_array)


def scenario_reference_lines() -> list[str]:
    """reStructuredText of the whole reference (one section per TOML table)."""
    from tmaplan.scenario import Scenario

    _check_units()
    lines: list[str] = []
    seen: set[tuple[str, type]] = set()
    for header, cls, array in _tables(Scenario, "", False):
        if (header, cls) in seen:
            continue
        seen.add((header, cls))
        hints = typing.get_type_hints(cls, include_extras=True)
        summary, docs = _field_docs(cls)
        title = "Top level" if not header else (f"[[{header}]]" if array else f"[{header}]")
        kind = next((f.default for f in dataclasses.fields(cls) if f.name == "kind"), None)
        if isinstance(kind, str) and kind:
            title += f' with kind = "{kind}"'
        title = f"{title} — {cls.__name__}"
        lines += [title, "-" * len(title), ""]
        lines += [f"Python: :class:`tmaplan.scenario.{cls.__name__}`.", ""]
        if summary:
            lines += [*summary.splitlines(), ""]
        lines += [".. list-table::", "   :header-rows: 1", "   :widths: 16 34 12 38", "",
                  "   * - key", "     - type and unit", "     - default", "     - description"]
        for f in dataclasses.fields(cls):
            if _dataclasses_in(hints[f.name]):
                tp, _ = _strip_optional(hints[f.name])
                is_array = typing.get_origin(tp) is tuple
                name = f"{header}.{f.name}" if header else f.name
                sub = "[[" + name + "]]" if is_array else "[" + name + "]"
                typ = f"table{'s' if is_array else ''} ``{sub}`` (below)"
            else:
                typ = describe_type(hints[f.name])
            desc = docs.get(f.name)
            if desc is None:
                raise ExtensionError(f"scenario_reference: {cls.__name__}.{f.name} has no entry "
                                     "in the class docstring's Attributes section")
            lines += [f"   * - ``{f.name}``", f"     - {typ}", f"     - {_default(f)}",
                      f"     - {desc or '—'}"]
        lines.append("")
    return lines


class ScenarioReference(SphinxDirective):
    """``.. scenario-reference::`` — insert the generated reference."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        container = nodes.section()
        container.document = self.state.document
        content = StringList(scenario_reference_lines(), source="<scenario-reference>")
        nested_parse_with_titles(self.state, content, container)
        return container.children


def setup(app: Sphinx) -> dict[str, Any]:
    """Register the directive."""
    app.add_directive("scenario-reference", ScenarioReference)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
