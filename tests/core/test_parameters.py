"""The parameter table: one fact per parameter, and everything derived from it agrees."""

import inspect
import re

import numpy as np
import pytest

from napari_labyrinth import PARAMETERS, PRESETS, labyrinth
from napari_labyrinth.core.codes import OPTION_CODES
from napari_labyrinth.core.parameters import (
    SEED,
    SWEEPABLE,
    LabyrinthParameters,
    format_value,
    make_parameters,
)


def _numpydoc_parameters(doc: str) -> dict[str, tuple[str, str]]:
    """``{name: (type, description)}`` of a numpydoc Parameters section."""
    section = doc.split("Parameters\n    ----------\n", 1)[1].split("\n\n    Returns", 1)[0]
    entries = {}
    for match in re.finditer(r"^    (\w+) : (.+)\n((?:        .*\n?)*)", section, re.M):
        name, type_text, description = match.groups()
        entries[name] = (type_text, " ".join(description.split()))
    return entries


def _references(equation: str) -> list[str]:
    """``"Eq. 2, 4"`` -> ``["Eq. 2", "Eq. 4"]``."""
    kind, numbers = equation.split(" ", 1)
    return [f"{kind} {number.strip()}" for number in numbers.split(",")]


def test_labyrinth_signature_has_every_parameter_keyword_only_defaulting_to_the_preset():
    signature = inspect.signature(labyrinth)
    for name in PARAMETERS:
        assert name in signature.parameters, name
        assert signature.parameters[name].kind is inspect.Parameter.KEYWORD_ONLY, name
        assert signature.parameters[name].default is None, name


@pytest.mark.parametrize("name", list(PARAMETERS))
def test_labyrinth_docstring_agrees_with_the_table(name):
    documented = _numpydoc_parameters(labyrinth.__doc__)
    parameter = PARAMETERS[name]
    type_text, description = documented[name]
    assert type_text == f"{parameter.type_text}, optional"
    for reference in _references(parameter.equation):
        assert reference in description, (name, reference)


def test_every_keyword_of_labyrinth_is_documented():
    documented = _numpydoc_parameters(labyrinth.__doc__)
    assert list(documented) == list(inspect.signature(labyrinth).parameters)


def test_docstring_checker_sees_a_drift():
    drifted = labyrinth.__doc__.replace('"serpentine", "checkerboard"}', '"serpentine"}')
    type_text, _ = _numpydoc_parameters(drifted)["scan"]
    assert type_text != f"{PARAMETERS['scan'].type_text}, optional"


def test_choices_are_the_kernel_codes_names():
    for name, codes in OPTION_CODES.items():
        assert PARAMETERS[name].choices == tuple(codes)


def test_the_paper_preset_is_the_table_paper_column():
    assert dict(PRESETS["paper"]) == {name: p.paper for name, p in PARAMETERS.items()}
    assert set(PRESETS["labyrinth"]) == set(PARAMETERS)


def test_the_dataclass_docstring_lists_every_parameter_with_its_equation():
    for name, parameter in PARAMETERS.items():
        assert f"{name} : {parameter.type_text}" in LabyrinthParameters.__doc__
    assert "t of Eq. 2" in PARAMETERS["mean_threshold"].tooltip
    assert "Paper: 0.12." in PARAMETERS["mean_threshold"].tooltip


@pytest.mark.parametrize(
    "name,text,value",
    [
        ("mean_threshold", " 0.2 ", 0.2),
        ("max_tries", "7", 7),
        ("passes", "1000", 1000),
        ("tone_ranges", "4", 4),
        ("tone_ranges", "10, 100, 255", (10.0, 100.0, 255.0)),
        ("include_centre", "Yes", True),
        ("include_centre", "0", False),
        ("border", "mirror", "mirror"),
        ("seed", "9223372036854775807", 2**63 - 1),
    ],
)
def test_text_values_parse_to_the_parameter_type(name, text, value):
    parameter = SEED if name == "seed" else PARAMETERS[name]
    parsed = parameter.parse(text)
    assert parsed == value and type(parsed) is type(value)  # a count stays a count


@pytest.mark.parametrize(
    "name,text,match",
    [
        ("mean_threshold", "abc", "mean_threshold must be a number"),
        ("mean_threshold", "-1", "mean_threshold must be finite and between 0 and 1e\\+06"),
        ("passes", "1001", "passes must be between 0 and 1000"),
        ("passes", "1.5", "passes must be a whole number"),
        ("max_tries", "10001", "between 0 and 10000"),
        ("border", "reflect", "border must be one of 'inside', 'mirror'"),
        ("include_centre", "maybe", "include_centre must be true or false"),
        ("tones", "1,2", "tones cannot be given as text"),
        ("seed", "-1", "seed must be between 0 and 2\\*\\*63 - 1"),
    ],
)
def test_bad_text_values_name_the_parameter_and_its_bounds(name, text, match):
    parameter = SEED if name == "seed" else PARAMETERS[name]
    with pytest.raises(ValueError, match=match):
        parameter.parse(text)



@pytest.mark.parametrize(
    ("name", "text", "values"),
    [
        ("variance_threshold", "0.47, 0.50;0.53", [0.47, 0.5, 0.53]),
        ("variance_threshold", "0.02,0.04", [0.02, 0.04]),
        ("variance_threshold", "0, 1", [0.0, 1.0]),
        ("mean_threshold", "\t0.1\n0.2 ", [0.1, 0.2]),
        ("passes", "1,2,04", [1, 2, 4]),  # whole numbers have no decimal comma
        ("seed", "3,4", [3, 4]),
        ("border", "inside, wrap", ["inside", "wrap"]),
    ],
)
def test_values_typed_as_text_split_at_commas_semicolons_and_spaces(name, text, values):
    assert SWEEPABLE[name].parse_values(text) == values


@pytest.mark.parametrize(
    ("text", "read"),
    [
        ("0,04", "0 and 04"),  # was the sweep [0, 4]
        ("0,02 0,04", "0, 02, 0 and 04"),
        ("0.02,0,04", "0.02, 0 and 04"),
        ("0,5", "0 and 5"),
        ("1,2", "1 and 2"),
    ],
)
def test_a_decimal_comma_is_refused_not_read_as_two_values(text, read):
    with pytest.raises(ValueError) as error:
        SWEEPABLE["variance_threshold"].parse_values(text)
    message = str(error.value)
    assert message.startswith(f"variance_threshold: {text!r} has a decimal comma")
    assert f"read as the values {read})" in message and "with a point" in message


def test_no_value_typed_is_refused_naming_the_parameter():
    for text in ("", " , ;"):
        with pytest.raises(ValueError, match="at least one value of seed to sweep"):
            SWEEPABLE["seed"].parse_values(text)


@pytest.mark.parametrize(
    ("name", "text", "number", "where"),
    [
        ("variance_threshold", "0.03,,0.05", 2, "between 0.03 and 0.05"),
        ("variance_threshold", "0.03, ,0.05", 2, "between 0.03 and 0.05"),
        ("variance_threshold", "0.03;;0.05", 2, "between 0.03 and 0.05"),
        ("variance_threshold", "0.03,0.05,", 3, "after 0.05"),  # a trailing comma
        ("variance_threshold", " ,0.03 ", 1, "before 0.03"),
        ("seed", "1,2,,,3", 3, "between 2 and 3"),
        ("border", "inside,,wrap", 2, "between inside and wrap"),
    ],
)
def test_an_empty_value_is_refused_naming_the_parameter_and_which_value(
    name, text, number, where
):
    # "0.03,,0.05" was read as the sweep [0.03, 0.05], the empty value skipped
    with pytest.raises(ValueError) as error:
        SWEEPABLE[name].parse_values(text)
    empty = f"value {number} of {text.strip()!r} is empty ({where})"
    assert str(error.value).startswith(f"{name}: {empty}: separate the values with one comma")


@pytest.mark.parametrize(
    ("name", "text", "values"),
    [
        ("variance_threshold", "0.03 , 0.05", [0.03, 0.05]),  # spaces around one comma
        ("variance_threshold", " 0.03 ,\t0.05 ; 0.07 ", [0.03, 0.05, 0.07]),
        ("variance_threshold", "0.03  0.05", [0.03, 0.05]),  # spaces alone separate
        ("variance_threshold", "1e-4, 2e-4", [1e-4, 2e-4]),
    ],
)
def test_one_separator_with_spaces_around_it_leaves_no_value_empty(name, text, values):
    assert SWEEPABLE[name].parse_values(text) == values


@pytest.mark.parametrize(
    ("name", "text", "match"),
    [
        ("variance_threshold", "0.03:0.05", "number; got '0.03:0.05': a sweep has no range"),
        ("variance_threshold", "0.03..0.05", "number; got '0.03..0.05': a sweep has no range"),
        ("passes", "1-4", "passes must be a whole number; got '1-4': a sweep has no range"),
        ("variance_threshold", "0.03,abc", "^variance_threshold must be a number; got 'abc'$"),
        ("seed", "1 -2", "^seed must be between 0 and 2\\*\\*63 - 1, got -2$"),
    ],
)
def test_a_value_that_is_not_one_is_refused_with_a_hint_for_ranges(name, text, match):
    with pytest.raises(ValueError, match=match):
        SWEEPABLE[name].parse_values(text)


@pytest.mark.parametrize(
    "value, text",
    [
        (0.04, "0.04"),
        (True, "true"),
        ("inside", "inside"),
        (3, "3"),
        ((0.0, 10.0, 91.66666666666667, 173.33333333333334, 255.0), "0,10,91.67,173.3,255"),
        ([10, 120.5, 255], "10,120.5,255"),
        (np.array([10.0, 255.0]), "10,255"),
        (np.float32(1 / 3), "0.3333"),
    ],
)
def test_values_in_words_read_as_they_are_typed(value, text):
    assert format_value(value) == text


def test_bounds_hold_in_the_api():
    base = dict(PRESETS["paper"])
    with pytest.raises(ValueError, match="passes must be between 0 and 1000"):
        make_parameters(**dict(base, passes=10**12))
    make_parameters(**dict(base, passes=1000))


def test_sweepable_is_every_one_word_parameter_and_the_seed():
    assert list(SWEEPABLE) == [n for n in PARAMETERS if n != "tones"] + ["seed"]


def test_a_call_is_resolved_once_and_keyed_by_the_types_of_its_values():
    import numpy as np

    from napari_labyrinth.core import presets
    from napari_labyrinth.core.presets import resolve_parameters

    first = resolve_parameters("paper", passes=1, mean_threshold=0.2)
    assert resolve_parameters("paper", passes=1, mean_threshold=0.2) is first
    # equal in Python, not as parameters: refused as if the first call had not been made
    with pytest.raises(TypeError, match="passes"):
        resolve_parameters("paper", passes=True, mean_threshold=0.2)
    with pytest.raises(TypeError, match="passes"):
        resolve_parameters("paper", passes=1.0, mean_threshold=0.2)
    with pytest.raises(ValueError, match="preset"):
        resolve_parameters("papers", passes=1, mean_threshold=0.2)
    # values of other types (a list, a numpy scalar) are resolved every time, alike
    by_list = resolve_parameters("paper", tone_ranges=[10.0, 100.0, 255.0])
    assert by_list == resolve_parameters("paper", tone_ranges=(10.0, 100.0, 255.0))
    assert resolve_parameters("paper", passes=np.int64(1), mean_threshold=0.2) == first
    for passes in range(2 * presets._RESOLVED_CALLS):  # the calls kept stay few
        resolve_parameters("paper", passes=passes)
    assert len(presets._RESOLVED) <= presets._RESOLVED_CALLS
