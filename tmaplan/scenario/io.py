"""Scenario TOML load/dump, validation errors in one line, and the built-in problem registry.

Load -> dump -> load is the identity (SI values, ``repr`` floats). Every invalid value raises
:class:`tmaplan.errors.ScenarioError` naming the field, the expected and the received value.
The public names are re-exported by :mod:`tmaplan.scenario`.
"""

from __future__ import annotations

import dataclasses
import os
import tomllib
from collections.abc import Mapping
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import tomli_w
from pydantic import TypeAdapter, ValidationError

from tmaplan.errors import ScenarioError
from tmaplan.scenario.bare import check_bare_numbers, with_units
from tmaplan.scenario.checks import check
from tmaplan.scenario.contacts import CONTACT_FIELDS, single_form
from tmaplan.scenario.names import DEFAULT_CONTACT
from tmaplan.scenario.plausible import warn as warn_implausible
from tmaplan.scenario.schema import Scenario

__all__ = [
    "dump",
    "from_dict",
    "list_problems",
    "load",
    "load_problem",
    "loads",
    "problems_dir",
    "save",
    "to_dict",
]


@cache
def _adapter() -> TypeAdapter[Scenario]:
    return TypeAdapter(Scenario)


def _loc(loc: tuple[Any, ...]) -> str:
    out = ""
    for i, part in enumerate(loc):
        if isinstance(part, int):
            out += f"[{part}]"
        elif i >= 2 and loc[i - 2] == "sensors" and isinstance(loc[i - 1], int) \
                and part in ("bearing", "range", "frequency"):  # a sensor's discriminator tag
            continue
        else:
            out += ("." if out else "") + str(part)
    return out or "<root>"


def _contact_loc(loc: tuple[Any, ...], contacts: Any, single: bool) -> tuple[tuple[Any, ...],
                                                                            str]:
    """``loc`` of an error inside ``contacts`` as the file gives it (the single form's
    ``target.…``), and ``" (contact 'name')"`` to name a ``[[contacts]]`` table's contact."""
    if len(loc) < 2 or loc[0] != "contacts" or not isinstance(loc[1], int):
        return loc, ""
    if single:
        return loc[2:], ""
    item = contacts[loc[1]] if isinstance(contacts, list) and loc[1] < len(contacts) else None
    name = item.get("name") if isinstance(item, dict) else None
    return loc, (f" (contact '{name}')" if isinstance(name, str) else "")


def _convert_validation_error(exc: ValidationError, source: str | None, contacts: Any = None,
                              single: bool = False) -> ScenarioError:
    e = exc.errors()[0]
    loc, whose = _contact_loc(tuple(e["loc"]), contacts, single)
    field = _loc(loc)
    msg = str(e["msg"])
    received = e.get("input")
    kind = e["type"]
    if kind in ("extra_forbidden", "unexpected_keyword_argument"):
        expected = "no such key (check the spelling; see the Scenario docs for valid keys)"
    elif kind == "missing":
        expected = "a value (this key is required)"
        received = None
    elif kind in ("union_tag_invalid", "union_tag_not_found"):
        expected = "kind = 'bearing', 'range' or 'frequency'"
        field += ".kind"
        received = received.get("kind") if isinstance(received, dict) else received
    elif kind == "bool_type":  # booleans are strict: "yes", 1 or "on" is refused
        expected = "a boolean (true or false)"
    else:
        cause = (e.get("ctx") or {}).get("error")
        if isinstance(cause, ScenarioError):  # a unit error raised by our own parser
            expected, received = cause.expected, cause.received
        else:
            expected = msg.removeprefix("Value error, ").removeprefix("Input should be ")
    if isinstance(received, dict):
        received = "{" + ", ".join(received) + "}"
    return ScenarioError(field, expected + whose, received, source=source)


def _with_contacts(data: Mapping[str, Any], source: str | None) -> tuple[dict[str, Any], bool]:
    """``data`` with a bare ``[target]``/``[prior]`` moved into ``contacts`` (one contact
    named ``"contact"``), and whether the file used that single form."""
    data = dict(data)
    given = [k for k in CONTACT_FIELDS if k in data]
    if "contacts" in data:
        if given:
            raise ScenarioError(given[0], "either [[contacts]] tables or a bare [target]/"
                                "[prior], not both (move it into a [[contacts]] table)",
                                "{" + ", ".join(given) + "}", source=source)
        contacts = data["contacts"]
        if isinstance(contacts, Mapping):  # `[contacts]` for `[[contacts]]`
            raise ScenarioError("contacts", "[[contacts]] tables, one per contact (an array of "
                                "tables: double brackets)", "a single [contacts] table {"
                                + ", ".join(map(str, contacts)) + "}", source=source)
        return data, False
    contact: dict[str, Any] = {"name": DEFAULT_CONTACT}
    for key in given:
        contact[key] = data.pop(key)
    data["contacts"] = [contact]
    return data, True


def from_dict(data: Mapping[str, Any], *, source: str | None = None) -> Scenario:
    """Build and validate a scenario from a plain dict (as read from TOML).

    Bare numbers are SI; a bare angle or turn rate that is implausible in SI (surely
    degrees) is refused, see :mod:`tmaplan.scenario.bare`.

    Raises
    ------
    ScenarioError
        Naming the field, the expected and the received value.
    """
    if not isinstance(data, Mapping):
        raise ScenarioError("<root>", "a table of scenario fields", type(data).__name__,
                            source=source)
    check_bare_numbers(data, source)
    data, single = _with_contacts(data, source)
    try:
        scenario = _adapter().validate_python(data)
    except ValidationError as exc:
        raise _convert_validation_error(exc, source, data["contacts"], single) from None
    check(scenario, source)
    warn_implausible(scenario, source)  # a course of 400°, a bearing σ of 90°, ...
    return scenario


def _strip_none(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _strip_none(v) for k, v in obj.items() if v is not None}
    if isinstance(obj, list | tuple):
        return [_strip_none(v) for v in obj]
    return obj


def to_dict(scenario: Scenario) -> dict[str, Any]:
    """Plain-dict (TOML-ready) form of a scenario, SI values, ``None`` fields omitted.

    A scenario of one default contact (:func:`tmaplan.scenario.contacts.single_form`) is
    written with a bare ``target`` and ``prior`` in their places of a one-contact file; any
    other as a list ``contacts``.
    """
    out = _strip_none(dataclasses.asdict(scenario))
    if not single_form(scenario):
        return out
    contact = out.pop("contacts")[0]
    order = ("name", "description", "time", "target", "observer", "sensors", "prior")
    merged = {**out, **{k: contact[k] for k in CONTACT_FIELDS if k in contact}}
    return {k: merged[k] for k in (*order, *out) if k in merged}


def dump(scenario: Scenario) -> str:
    """TOML text of a scenario. ``loads(dump(s)) == s`` exactly.

    Values are SI numbers; angles and turn rates that a file could not give as bare numbers
    (e.g. a bearing noise above 0.2 rad) carry their SI unit (``"0.3 rad"``).
    """
    return tomli_w.dumps(with_units(to_dict(scenario)))


def loads(text: str, *, source: str | None = None) -> Scenario:
    """Parse TOML text into a validated :class:`Scenario`."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError("<file>", "valid TOML", str(exc), source=source) from None
    return from_dict(data, source=source)


def problems_dir() -> Path:
    """Directory of the built-in problem files (``$TMAPLAN_PROBLEMS`` overrides).

    The files are package data of :mod:`tmaplan`, found with :func:`importlib.resources.files`
    in a source checkout, an editable install and an installed wheel alike (in the repository,
    ``tmaplan/problems`` is a link to the top-level ``problems/`` folder).
    """
    env = os.environ.get("TMAPLAN_PROBLEMS")
    if env:
        return Path(env)
    return Path(str(resources.files("tmaplan") / "problems"))


def list_problems() -> list[dict[str, str]]:
    """Built-in problems as ``[{name, description}]``, sorted by name.

    Raises
    ------
    ScenarioError
        If the problem folder holds no ``.toml`` file (a broken installation).
    """
    folder = problems_dir()
    out = []
    for path in sorted(folder.glob("*.toml")):
        with path.open("rb") as fh:
            data = tomllib.load(fh)
        out.append({"name": path.stem, "description": str(data.get("description", ""))})
    if not out:
        raise ScenarioError("problems", "built-in problem files (*.toml) in the package",
                            f"none in {folder}")
    return out


def load_problem(name: str) -> Scenario:
    """Load a built-in problem by name.

    Raises
    ------
    ScenarioError
        If there is no such problem; the message lists the valid names.
    """
    path = problems_dir() / f"{name}.toml"
    if not path.is_file():
        names = ", ".join(p["name"] for p in list_problems())
        raise ScenarioError("problem", f"one of: {names}", name)
    return loads(path.read_text(encoding="utf-8"), source=name)


def _read_text(path: Path) -> str:
    """The UTF-8 text of a scenario file; a binary or undecodable file names the file."""
    data = path.read_bytes()
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError("<file>", "a UTF-8 text file in TOML format (is it a binary file?)",
                            f"undecodable byte 0x{data[exc.start]:02x} at offset {exc.start}",
                            source=str(path)) from None


def load(name_or_path: str | os.PathLike[str]) -> Scenario:
    """Load a scenario from a TOML file path or a built-in problem name.

    An existing file is read as a scenario file; a name ending in ``.toml`` or naming an
    existing directory must be such a file, except that a directory named like a built-in
    problem (``./default/``, an output folder say) does not hide the problem.
    """
    path = Path(name_or_path)
    builtin = (problems_dir() / f"{path.name}.toml").is_file() and str(name_or_path) == path.name
    if path.is_file() or path.suffix == ".toml" or (path.exists() and not builtin):
        if not path.is_file():
            names = ", ".join(p["name"] for p in list_problems())
            raise ScenarioError("problem", f"an existing .toml file or one of: {names}",
                                str(name_or_path))
        return loads(_read_text(path), source=str(path))
    return load_problem(str(name_or_path))


def save(scenario: Scenario, path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
    """Write a scenario as TOML. Refuses to overwrite an existing file unless asked."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True to replace it")
    path.write_text(dump(scenario), encoding="utf-8")
    return path
