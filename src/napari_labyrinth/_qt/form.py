"""The parameter fields: preset, the paper's parameters, the reading options, the seed.

The fields are defined in one place, ``MAIN_FIELDS`` and ``READING_FIELDS``
(label or choices, and a tooltip citing the paper). Choosing a preset fills
every field; a field edited afterwards overrides the preset
(:func:`napari_labyrinth.plan.overrides`).
"""

from __future__ import annotations

from typing import Any

from magicgui.widgets import CheckBox, ComboBox, Container, FloatSpinBox, Label, SpinBox

from .. import parameters, presets
from ..plan import FLOAT_PARAMETERS, edited_text, overrides, preset_field_values

#: Parameters edited in the main section, in order: (label, tooltip citing the paper).
MAIN_FIELDS = {
    "mean_threshold": (
        "mean threshold t",
        (
            "t of Eq. 2: a pixel of tone g keeps it when |g - M| / M <= t, M being the mean "
            "of its 8 nearest and next-nearest neighbours (Eq. 1). Paper: 0.12."
        ),
    ),
    "variance_threshold": (
        "variance threshold V",
        (
            "V of Eq. 4: where R2 = sqrt(V/N)/M > V the substitution g -> g* is not applied "
            "(or g is pushed away from M, see 'variance action'). Paper: 0.50. The labyrinth "
            "appears only in a narrow range of V (Fig. 3)."
        ),
    ),
    "tone_ranges": (
        "tone ranges",
        (
            "Number of about-equal tone ranges from a low tone (10) to 255; Eq. 3 draws "
            "g* = T_inf + R (T_sup - T_inf) in the range holding g. Paper: 3. A preset's own "
            "range limits and tones are kept until this count is changed."
        ),
    ),
    "max_tries": (
        "max tries",
        (
            "Draws of Eq. 3 per pixel before giving up ('till condition (2) is satisfied or "
            "the number of iterations exceeds a fixed value'; the paper gives no number)."
        ),
    ),
    "passes": (
        "passes",
        (
            "Passes over the image: Fig. 4 applies the algorithm several times to enhance "
            "edges. Stack mode keeps the image after every pass."
        ),
    ),
}

#: Reading options (the points the paper leaves open), in the collapsible section.
READING_FIELDS = {
    "variance_ratio": (
        parameters.VARIANCE_RATIOS,
        "R2 of Eq. 4: sqrt(V/N)/M as printed, or sqrt(V)/M (the coefficient of variation).",
    ),
    "variance_action": (
        parameters.VARIANCE_ACTIONS,
        (
            "Where Eq. 4 holds: 'leave' g as printed ('the substitution is not applied'), or "
            "push it further from M with a draw on its side of M (the push readings of 'a "
            "condition able to strongly enhance the local variance'; see docs/algorithm.md)."
        ),
    ),
    "condition_order": (
        parameters.CONDITION_ORDERS,
        "Which condition decides first: Eq. 2 (as printed) or Eq. 4.",
    ),
    "border": (
        parameters.BORDERS,
        (
            "Neighbours of border pixels: only those inside the image (N of Eq. 1 is their "
            "number), or completed like the scipy.ndimage modes of the same name."
        ),
    ),
    "on_exhausted": (
        parameters.ON_EXHAUSTED,
        (
            "What a pixel becomes when none of the 'max tries' draws of Eq. 3 satisfies Eq. 2: "
            "it keeps its tone, or takes the last draw."
        ),
    ),
    "include_centre": (
        None,
        "Whether the pixel joins its own M and V (Eq. 1 sums over the neighbours only).",
    ),
    "scan": (
        parameters.SCANS,
        (
            "Scan order from the top-left corner: every row left to right (raster), or odd rows "
            "right to left (serpentine)."
        ),
    ),
}

_SEED_MAX = 2**63 - 1
_PASSES_MAX = 1000


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
            choices=list(presets.PRESETS),
            tooltip="A named parameter set: choosing one fills every field; a field edited "
            "afterwards overrides the preset.",
        )
        self.edited = Label(value="")
        self.edited.native.setStyleSheet("color: gray")
        self.fields: dict[str, Any] = {name: _main_field(name) for name in MAIN_FIELDS}
        self.seed = SpinBox(
            label="seed",
            min=0,
            max=_SEED_MAX,
            tooltip="Seed of the random draws of Eq. 3: the result is a pure function of the "
            "image, the parameters and the seed.",
        )
        reading = [_reading_field(name) for name in READING_FIELDS]
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


def _main_field(name: str):
    label, tooltip = MAIN_FIELDS[name]
    if name in FLOAT_PARAMETERS:
        widget = FloatSpinBox(label=label, min=0.0, max=100.0, step=0.01, tooltip=tooltip)
        widget.native.setDecimals(4)
        return widget
    if name == "tone_ranges":
        return SpinBox(label=label, min=1, max=255, tooltip=tooltip)
    if name == "max_tries":
        return SpinBox(label=label, min=0, max=parameters.MAX_TRIES_LIMIT, tooltip=tooltip)
    return SpinBox(label=label, min=0, max=_PASSES_MAX, tooltip=tooltip)


def _reading_field(name: str):
    choices, tooltip = READING_FIELDS[name]
    label = name.replace("_", " ")
    if choices is None:
        return CheckBox(text=label, tooltip=tooltip)
    return ComboBox(label=label, choices=list(choices), tooltip=tooltip)
