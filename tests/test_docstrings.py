"""Every public name carries numpydoc sections and a runnable example, and the example runs (issue 22, item 5).

The public names are ``omegahat.__all__`` and ``omegahat.identification.__all__`` (classes and functions; the
version string, constants and type aliases have no signature to document). Each docstring is checked by numpydoc's
own validator (``numpydoc.validate``, the checker NumPy and SciPy use) for the sections a user reads — every
parameter documented and none invented (PR01, PR02, PR03, PR07), a Returns section on functions (RT01), an Examples
section (EX01) — and its examples are run by :mod:`doctest`: an example that no longer prints what it shows fails.
Style codes (summary length, See Also, type spellings) are not checked.
"""

from __future__ import annotations

import doctest
import enum
import inspect

import pytest
from numpydoc.validate import validate

import omegahat
import omegahat.identification

CHECKED_CODES = {"GL08", "PR01", "PR02", "PR03", "PR07", "RT01", "EX01"}


def _public_names() -> list[str]:
    names = []
    for module in (omegahat, omegahat.identification):
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isclass(obj) or inspect.isfunction(obj):
                names.append(f"{module.__name__}.{name}")
    return names


PUBLIC = _public_names()


def _resolve(qualified: str) -> object:
    module_name, _, name = qualified.rpartition(".")
    module = omegahat.identification if module_name == "omegahat.identification" else omegahat
    return getattr(module, name)


def test_the_public_names_are_found() -> None:
    # the list the other tests run over is not empty by accident (a renamed __all__ would make them vacuous)
    assert len(PUBLIC) >= 35
    assert "omegahat.SarrasEstimator" in PUBLIC and "omegahat.identification.identify" in PUBLIC


@pytest.mark.parametrize("qualified", PUBLIC)
def test_numpydoc_sections(qualified: str) -> None:
    obj = _resolve(qualified)
    codes = set(CHECKED_CODES)
    if inspect.isclass(obj) and issubclass(obj, enum.Enum | BaseException):
        # an enumeration's or an exception's "parameters" are the machinery of Enum/Exception, not its API
        codes -= {"PR01", "PR02"}
    errors = [f"{code}: {message}" for code, message in validate(qualified)["errors"] if code in codes]
    assert not errors, "\n".join(errors)


@pytest.mark.parametrize("qualified", PUBLIC)
def test_examples_run(qualified: str) -> None:
    obj = _resolve(qualified)
    # the class's or function's own docstring only: its methods' examples (if any) are not the name's example
    tests = doctest.DocTestFinder(recurse=False).find(obj, qualified, globs={})
    examples = [test for test in tests if test.examples]
    assert examples, f"{qualified}: no runnable example in its docstring"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in examples:
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{qualified}: {result.failed} of {result.attempted} example lines failed (above)"
