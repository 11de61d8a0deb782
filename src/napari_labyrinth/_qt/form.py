"""The parameter fields: preset, the paper's parameters, the reading options, the seed.

Every field is built from the parameter table
(:data:`napari_labyrinth.core.parameters.PARAMETERS`): its label, bounds or
choices, and a tooltip citing the paper's equation and value. The main
section holds the paper's parameters, the collapsible one the reading options
(the points the paper leaves open). Choosing a preset fills every field; a
field edited afterwards overrides the preset
(:func:`napari_labyrinth.widget.choices.overrides`).
"""

from __future__ import annotations

from typing import Any

from magicgui.widgets import CheckBox, ComboBox, Container, FloatSpinBox, Label, SpinBox

from ..core.parameters import FLOAT_DECIMALS, PARAMETERS, SEED, Parameter
from ..core.presets import PRESETS
from ..widget.choices import overrides, preset_field_values
from ..widget.text import edited_text

#: Parameters with a field: every one that takes one value (``tones`` is set by
#: its range count), the paper's in the main section, the readings apart.
MAIN_FIELDS = tuple(n for n, p in PARAMETERS.items() if p.kind != "tones" and not p.reading)
READING_FIELDS = tuple(n for n, p in PARAMETERS.items() if p.reading)

#: What a field means in the widget beyond the table's doc line.
_FIELD_NOTES = {
    "tone_ranges": "A preset's own range limits and tones are kept until this count changes.",
    "passes": "Stack mode keeps the image after every pass.",
}

#: Largest value a Qt spin box holds (a C int64 here); unbounded floats stop at
#: ``_FLOAT_FIELD_MAX``, far beyond any useful threshold.
_QT_INT_MAX = 2**63 - 1
_FLOAT_FIELD_MAX = 1e6


class ParameterForm:
    """The preset, one field per parameter of the algorithm (all but ``tones``) and the seed.

    Attributes
    ----------
    preset : magicgui.widgets.ComboBox
        Named parameter set that fills every parameter field.
    edited : magicgui.widgets.Label
        Which fields override the preset.
    fields : dict of str to magicgui widget
        One field per parameter, ``MAIN_FIELDS`` then ``READING_FIELDS``.
    seed : magicgui.widgets.SpinBox
    parameter_box : magicgui.widgets.Container
        The preset, the main fields and the seed.
    reading_box : magicgui.widgets.Container
        The reading options.
    """

    def __init__(self) -> None:
        self._filling = False
        self.preset = ComboBox(
            label="preset",
            choices=list(PRESETS),
            tooltip="A named parameter set: choosing one fills every field; a field edited "
            "afterwards overrides the preset.",
        )
        self.edited = Label(value="")
        self.edited.native.setStyleSheet("color: gray")
        self.fields: dict[str, Any] = {name: field(PARAMETERS[name]) for name in MAIN_FIELDS}
        self.seed = field(SEED)
        reading = [field(PARAMETERS[name]) for name in READING_FIELDS]
        self.fields.update(zip(READING_FIELDS, reading))
        preset_row = Container(
            widgets=[self.preset, self.edited], layout="horizontal", labels=False, label="preset"
        )
        preset_row.margins = (0, 0, 0, 0)
        self.parameter_box = Container(
            widgets=[preset_row] + [self.fields[name] for name in MAIN_FIELDS] + [self.seed]
        )
        self.reading_box = Container(widgets=reading)
        for widget in self.fields.values():
            widget.changed.connect(self._on_field_edited)

    def apply_preset(self, name: str) -> None:
        """Fill every parameter field from preset ``name``."""
        values = preset_field_values(name, list(self.fields))
        self._filling = True
        try:
            for field, widget in self.fields.items():
                widget.value = values[field]
        finally:
            self._filling = False
        self._on_field_edited()

    def _on_field_edited(self, *_args) -> None:
        if self._filling:
            return
        self.edited.value = edited_text(self.overrides())

    def values(self) -> dict[str, Any]:
        """Every field's value."""
        return {name: widget.value for name, widget in self.fields.items()}

    def overrides(self) -> dict[str, Any]:
        """The fields whose value differs from the chosen preset's."""
        return overrides(self.preset.value, self.values())

    def value(self, parameter: str) -> Any:
        """The value of a parameter field, or of the seed."""
        return self.seed.value if parameter == "seed" else self.fields[parameter].value


def field(parameter: Parameter):
    """The magicgui widget that edits ``parameter``, from its entry in the table."""
    tooltip = " ".join(filter(None, (parameter.tooltip, _FIELD_NOTES.get(parameter.name))))
    if parameter.kind == "choice":
        return ComboBox(label=parameter.label, choices=list(parameter.choices), tooltip=tooltip)
    if parameter.kind == "bool":
        return CheckBox(text=parameter.label, tooltip=tooltip)
    if parameter.kind == "float":
        high = _FLOAT_FIELD_MAX if parameter.high is None else parameter.high
        widget = FloatSpinBox(
            label=parameter.label, min=parameter.low, max=high, step=0.01, tooltip=tooltip
        )
        widget.native.setDecimals(FLOAT_DECIMALS)
        return widget
    # int, seed, and tone_ranges as a count of equal ranges
    high = min(parameter.high, _QT_INT_MAX)  # the table bounds every number
    return SpinBox(label=parameter.label, min=parameter.low, max=high, tooltip=tooltip)
