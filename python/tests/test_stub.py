"""The type stub (jeffcott/_jeffcott.pyi) says what the extension does: the same
functions, the same parameters in the same order and of the same kinds, the same
defaults; and the stepper's shared keywords are exactly the stepper's settings."""

import ast
import inspect
from pathlib import Path

import pytest

import jeffcott
from jeffcott import _jeffcott

STUB = Path(_jeffcott.__file__).with_name("_jeffcott.pyi")

def stub_tree():
    return ast.parse(STUB.read_text())


def stub_functions():
    return {n.name: n for n in stub_tree().body if isinstance(n, ast.FunctionDef)}


def stub_parameters(fn):
    """(name, kind, default node or None) of a stub's parameters, in order."""
    a = fn.args
    out = []
    positional = a.posonlyargs + a.args
    defaults = [None] * (len(positional) - len(a.defaults)) + list(a.defaults)
    for arg, d in zip(a.posonlyargs, defaults):
        out.append((arg.arg, "POSITIONAL_ONLY", d))
    for arg, d in zip(a.args, defaults[len(a.posonlyargs):]):
        out.append((arg.arg, "POSITIONAL_OR_KEYWORD", d))
    if a.vararg:
        out.append((a.vararg.arg, "VAR_POSITIONAL", None))
    for arg, d in zip(a.kwonlyargs, a.kw_defaults):
        out.append((arg.arg, "KEYWORD_ONLY", d))
    if a.kwarg:
        out.append((a.kwarg.arg, "VAR_KEYWORD", None))
    return out


def extension_functions():
    return {
        name: f
        for name, f in vars(_jeffcott).items()
        if callable(f) and not name.startswith("_") and not isinstance(f, type)
    }


def library_default(function, keyword):
    """The default the library declares for a keyword (DEFAULTS), None where none."""
    try:
        return jeffcott._library_default(function, keyword)
    except KeyError:
        return None


def test_the_stub_declares_exactly_the_extensions_functions():
    assert sorted(stub_functions()) == sorted(extension_functions())


@pytest.mark.parametrize("name", sorted(extension_functions()))
def test_the_stubs_parameters_are_the_extensions_in_order_and_kind(name):
    runtime = [
        (p.name, p.kind.name) for p in inspect.signature(getattr(_jeffcott, name)).parameters.values()
    ]
    stub = [(n, k) for n, k, _ in stub_parameters(stub_functions()[name])]
    assert stub == runtime


@pytest.mark.parametrize("name", sorted(extension_functions()))
def test_the_stubs_defaults_are_the_extensions(name):
    params = inspect.signature(getattr(_jeffcott, name)).parameters
    for keyword, _, node in stub_parameters(stub_functions()[name]):
        p = params[keyword]
        if node is None:
            assert p.default is inspect.Parameter.empty, f"{name}({keyword}) has a default"
            continue
        declared = ast.literal_eval(node)
        # The extension shows literal defaults; constants show as `...`, whose values
        # the library lists in DEFAULTS.
        actual = library_default(name, keyword) if p.default is Ellipsis else p.default
        assert type(declared) is type(actual) and declared == actual, (
            f"{name}({keyword}): stub {declared!r}, extension {actual!r}"
        )


@pytest.mark.parametrize("name", sorted(extension_functions()))
def test_a_literal_default_is_the_one_DEFAULTS_lists_for_that_keyword(name):
    for p in inspect.signature(getattr(_jeffcott, name)).parameters.values():
        listed = library_default(name, p.name)
        if p.default in (inspect.Parameter.empty, Ellipsis, None) or listed is None:
            continue
        assert p.default == listed, f"{name}({p.name}={p.default!r}), DEFAULTS says {listed!r}"


@pytest.mark.parametrize("name", sorted(extension_functions()))
def test_the_exported_functions_show_every_default_as_its_value(name):
    exported = inspect.signature(getattr(jeffcott, name)).parameters
    extension = inspect.signature(getattr(_jeffcott, name)).parameters
    assert list(exported) == list(extension)
    for p in exported.values():
        assert p.default is not Ellipsis, f"{name}({p.name}) shows `...`"
        if extension[p.name].default is Ellipsis:
            assert p.default == library_default(name, p.name)
    assert "..." not in str(inspect.signature(getattr(jeffcott, name)))


def test_the_stepper_keywords_are_exactly_the_stepper_settings_with_their_kinds():
    (options,) = [
        n for n in stub_tree().body if isinstance(n, ast.ClassDef) and n.name == "StepperOptions"
    ]
    declared = {a.target.id: a.annotation.id for a in options.body if isinstance(a, ast.AnnAssign)}
    kinds = {k: type(v).__name__ for k, v in jeffcott.STEPPER_DEFAULTS.items()}
    assert declared == kinds
    assert jeffcott.DEFAULTS["stepper"] == jeffcott.STEPPER_DEFAULTS
    # Every function that integrates takes them, as **stepper.
    takers = sorted(
        n for n, f in extension_functions().items()
        if any(p.kind is p.VAR_KEYWORD for p in inspect.signature(f).parameters.values())
    )
    assert takers == ["basin", "basin_stability", "bifurcation", "cascade", "continuation",
                      "ensemble", "lyapunov", "map", "orbits", "simulate"]


def test_a_stepper_keyword_reaches_the_stepper_and_an_unknown_keyword_is_refused():
    r = jeffcott.simulate(133.0, transient=1, periods=2, steps_per_period=300,
                          contact_substeps=4, exact_free_flight=True)
    assert r["stepper"]["steps_per_period"] == 300
    assert r["stepper"]["contact_substeps"] == 4
    assert r["stepper"]["exact_free_flight"] is True
    assert jeffcott.STEPPER_DEFAULTS["exact_free_flight"] is False
    assert r["stepper"]["max_segments"] == jeffcott.STEPPER_DEFAULTS["max_segments"]
    assert jeffcott.ensemble("133", transient=1, periods=1, backend="cpu",
                             steps_per_period=300)["run"]["steps_per_period"] == 300
    with pytest.raises(TypeError, match="basin\\(\\) got an unexpected keyword argument 'steps'"):
        jeffcott.basin(133.0, "x_r:-0.001:0.001:2", "vx_r:-1:1:2", steps=300)
    with pytest.raises(ValueError, match="`steps_per_period`"):
        jeffcott.simulate(133.0, steps_per_period=-5)
