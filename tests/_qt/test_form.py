"""The parameter form and the choices the widget hands to the plan."""

from __future__ import annotations

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari_labyrinth._qt.form import MAIN_FIELDS, READING_FIELDS
from napari_labyrinth.core.parameters import PARAMETERS, SEED
from napari_labyrinth.widget.choices import CURRENT_PLANE, Choices

from .helpers import noise


def test_the_fields_cover_every_parameter_but_the_tones_as_the_table_says(widget):
    assert set(MAIN_FIELDS) | set(READING_FIELDS) == set(PARAMETERS) - {"tones"}
    assert all(PARAMETERS[name].reading for name in READING_FIELDS)
    for name, field in [*widget.fields.items(), ("seed", widget.seed)]:
        parameter = SEED if name == "seed" else PARAMETERS[name]
        assert parameter.tooltip in field.tooltip, name
        if parameter.kind == "choice":
            assert tuple(field.choices) == parameter.choices, name
        elif parameter.kind == "bool":
            assert field.text == parameter.label
        else:
            assert field.label == parameter.label, name
            assert field.min == parameter.low, name
            if parameter.high is not None and parameter.high < 2**63:
                assert field.max == parameter.high, name


def test_a_sweep_proposes_values_around_the_field_s_value(widget):
    widget.preset.value = "paper"
    assert widget.sweep_values.value == "0.47, 0.5, 0.53"  # Fig. 3
    widget.fields["mean_threshold"].value = 0.1
    widget.sweep_parameter.value = "mean_threshold"
    assert widget.sweep_values.value == "0.08, 0.1, 0.12"
    widget.seed.value = 7
    widget.sweep_parameter.value = "seed"
    assert widget.sweep_values.value == "0, 1, 2"


def test_the_widget_hands_its_choices_to_the_plan_as_plain_values(viewer, widget):
    viewer.add_image(noise((3, 16, 16)), name="movie")
    assert widget.choices() == Choices(sweep_text="0.02, 0.04, 0.06")  # the widget's defaults
    widget.mode.value = "sweep"
    widget.preset.value = "paper"
    widget.fields["scan"].value = "serpentine"
    widget.seed.value = 3
    widget.follow_contrast.value = False
    widget.tone_low.value, widget.tone_high.value = "1", "2"
    widget.planes.value = CURRENT_PLANE
    widget.sweep_parameter.value = "passes"
    widget.sweep_values.value = "1 3"
    assert widget.choices() == Choices(
        mode="sweep",
        preset="paper",
        overrides={"scan": "serpentine"},
        seed=3,
        tone_limits=("1", "2"),
        planes=CURRENT_PLANE,
        sweep_parameter="passes",
        sweep_text="1 3",
    )
    viewer.dims.set_current_step(0, 2)
    plan = widget.plan()
    assert plan.source_index == (2,) and plan.arguments["values"] == [1, 3]


def test_the_noise_gate_field_follows_the_preset_and_an_edit_overrides_it(viewer, widget):
    field = widget.fields["noise_gate"]
    assert field in list(widget.form.reading_box)  # beside the readings, not the paper's
    assert "not in the paper" in field.tooltip
    widget.preset.value = "paper"
    assert field.value == 0.0
    widget.preset.value = "labyrinth"
    assert field.value == 2.0
    field.value = 1.5
    viewer.add_image(noise((16, 16)), name="dark")
    assert widget.choices().overrides == {"noise_gate": 1.5}
    assert widget.plan().arguments["noise_gate"] == 1.5
