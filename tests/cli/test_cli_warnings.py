"""The command line prints a warning as one line, as it prints errors."""

from __future__ import annotations

import warnings

import tmaplan.cli.simulate as simulate_verb
from tmaplan.cli import main
from tmaplan.estimators.particle_filter import DegeneracyWarning


def test_a_warning_is_one_line_naming_the_verb_and_its_category(monkeypatch, capsys):
    def run(args):
        warnings.warn("particle filter degenerate\nat step 3", DegeneracyWarning, stacklevel=1)

    monkeypatch.setattr(simulate_verb, "run", run)
    assert main(["simulate", "default"]) == 0
    err = capsys.readouterr().err
    # not Python's two lines (file:line: Category: text, then the source line)
    assert err == ("tmaplan simulate: warning: DegeneracyWarning: particle filter degenerate "
                   "at step 3\n"), err
    # the replacement is undone when main returns
    assert warnings.showwarning.__module__ == "warnings"
