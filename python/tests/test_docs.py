"""The docstrings (what ``help(jeffcott.basin)`` shows, written in python/src) and the
type stub (jeffcott/_jeffcott.pyi) name the same parameters.

Each function's docstring ends its description with a ``Parameters:`` list, one item per
parameter in the signature's order, written as the docstrings write names, in
backticks::

    Parameters:
    - `omega`: the rotor speed W [rad/s].
    - `x`, `y`: the axes, ...
      (continued on lines indented by two spaces)
    - `**stepper`: the lane stepper's settings, ...

Prose elsewhere in a docstring that writes a keyword with a value (``lyapunov=True``,
``refine > 0``) must name a parameter of that function too."""

import ast
import re
from pathlib import Path

import pytest

import jeffcott
from jeffcott import _jeffcott

STUB = Path(_jeffcott.__file__).with_name("_jeffcott.pyi")
HEADING = "Parameters:"
# An item's head: one or more backticked names, then a colon.
ITEM = re.compile(r"^- ((?:`[^`]+`(?:, | and )?)+):")
NAME = re.compile(r"`([^`]+)`")
# A backticked keyword with a value or a bound: `lyapunov=True`, `refine > 0` (not a
# key such as `fractions_<dir>`).
KEYWORD_IN_PROSE = re.compile(r"`([A-Za-z_][A-Za-z0-9_]*)(?:=|\s+[<>]=?\s+)[^`=][^`]*`")


def stub_signatures():
    """Each stub function's parameter names in order, `*args` and `**kwargs` with their
    stars."""
    out = {}
    for node in ast.parse(STUB.read_text()).body:
        if not isinstance(node, ast.FunctionDef):
            continue
        a = node.args
        names = [p.arg for p in a.posonlyargs + a.args]
        if a.vararg:
            names.append("*" + a.vararg.arg)
        names += [p.arg for p in a.kwonlyargs]
        if a.kwarg:
            names.append("**" + a.kwarg.arg)
        out[node.name] = names
    return out


def documented_parameters(doc):
    """The names the docstring's `Parameters:` list documents, in its order (empty without
    the list). The list runs from its heading to the first line that is neither an item
    nor an item's continuation (indented)."""
    lines = doc.splitlines()
    try:
        start = [line.strip() for line in lines].index(HEADING)
    except ValueError:
        return []
    names = []
    for line in lines[start + 1:]:
        m = ITEM.match(line)
        if m:
            names += NAME.findall(m.group(1))
        elif not line.startswith("  ") or not line.strip():
            break
    return names


def public_functions():
    return sorted(
        n for n in dir(jeffcott)
        if not n.startswith("_") and callable(getattr(jeffcott, n))
        and not isinstance(getattr(jeffcott, n), type)
    )


def docstring(name):
    doc = getattr(jeffcott, name).__doc__
    assert isinstance(doc, str) and doc.strip(), f"jeffcott.{name} has no docstring"
    return doc


def test_the_stub_declares_every_public_function():
    assert public_functions() == sorted(stub_signatures())


@pytest.mark.parametrize("name", sorted(stub_signatures()))
def test_every_stub_parameter_is_documented_and_every_documented_one_exists(name):
    stub = stub_signatures()[name]
    documented = documented_parameters(docstring(name))
    missing = [p for p in stub if p not in documented]
    extra = [p for p in documented if p not in stub]
    assert not missing, f"jeffcott.{name}: {missing} not in its docstring's {HEADING} list"
    assert not extra, f"jeffcott.{name}: {HEADING} documents {extra}, not in the stub"
    assert documented == stub, f"jeffcott.{name}: documented in another order than the stub's"


@pytest.mark.parametrize("name", sorted(stub_signatures()))
def test_a_keyword_the_prose_gives_a_value_is_a_parameter(name):
    stub = stub_signatures()[name]
    for keyword in KEYWORD_IN_PROSE.findall(docstring(name)):
        assert keyword in stub, f"jeffcott.{name}'s docstring writes `{keyword}=...`, not in the stub"


def test_the_list_parser_reads_items_continuations_and_pairs():
    doc = (
        "Text `refine > 0`, `lyapunov=True`, `fractions_<dir>`.\n\nParameters:\n- `omega`: a speed\n  over two lines.\n"
        "- `x`, `y`: the axes.\n- `**stepper`: settings.\n\nReturns nothing."
    )
    assert documented_parameters(doc) == ["omega", "x", "y", "**stepper"]
    assert documented_parameters("No list here, `omega` in prose.") == []
    assert KEYWORD_IN_PROSE.findall(doc) == ["refine", "lyapunov"]
