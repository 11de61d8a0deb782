"""The provenance record: one schema for layers and files, exact through JSON."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

import napari_labyrinth
from napari_labyrinth import api, provenance, samples
from napari_labyrinth.core.presets import resolve_parameters
from napari_labyrinth.widget.choices import Choices, LayerSnapshot
from napari_labyrinth.widget.layer_kwargs import METADATA_KEY
from napari_labyrinth.widget.plan import make_plan


def test_file_checksum_is_sha256_of_the_bytes(tmp_path):
    path = tmp_path / "f.bin"
    path.write_bytes(b"labyrinth")
    assert provenance.file_checksum(path) == hashlib.sha256(b"labyrinth").hexdigest()


def test_a_store_checksum_covers_names_and_bytes(tmp_path):
    store = tmp_path / "s.zarr"
    (store / "0").mkdir(parents=True)
    (store / "zarr.json").write_text("{}")
    (store / "0" / "c").write_bytes(b"\x01")
    first = provenance.file_checksum(store)
    (store / ".hidden.tmp").write_bytes(b"ignored")  # a temporary of a writer
    assert provenance.file_checksum(store) == first
    (store / "0" / "c").write_bytes(b"\x02")
    assert provenance.file_checksum(store) != first


def _record(**changes):
    parameters = resolve_parameters("labyrinth", passes=2).as_dict()
    arguments = provenance.call_arguments(
        preset="labyrinth",
        parameters=parameters,
        seed=7,
        tone_limits=(0.1, 1 / 3),
        channel_axis=None,
    )
    fields = dict(
        mode="single",
        preset="labyrinth",
        overrides={"passes": 2},
        parameters=parameters,
        seed=7,
        tone_limits=(0.1, 1 / 3),
        arguments=arguments,
        sweep=None,
        source=provenance.input_record("in.tif", (8, 9), np.uint16, "0" * 64),
    )
    return provenance.make_record(**dict(fields, **changes))


def test_a_record_survives_json_exactly():
    record = _record()
    back = provenance.from_json(provenance.to_json(record))
    assert back == record
    assert back["tone_limits"][1] == 1 / 3  # not rounded
    assert back["version"] == napari_labyrinth.__version__
    source = {"name": "in.tif", "sha256": "0" * 64, "shape": [8, 9], "dtype": "uint16"}
    assert back["input"] == source


def test_reproduce_call_renders_what_the_record_says():
    image = np.random.default_rng(0).integers(0, 4000, (8, 9)).astype(np.uint16)
    record = provenance.from_json(provenance.to_json(_record()))
    mode, arguments = provenance.reproduce_call(record)
    *_, result = api.labyrinth_steps(image, mode, **arguments)
    expected = api.labyrinth(image, passes=2, seed=7, tone_limits=(0.1, 1 / 3))
    np.testing.assert_array_equal(result.image, expected)


def test_a_sweep_record_calls_labyrinth_sweep():
    record = _record(mode="sweep", sweep=("passes", [1, 2]))
    assert record["function"] == "labyrinth_sweep"
    arguments = provenance.call_arguments(
        preset="labyrinth",
        parameters=record["parameters"],
        seed=7,
        tone_limits=None,
        channel_axis=None,
        sweep=("passes", [1, 2]),
    )
    assert "passes" not in arguments and arguments["values"] == [1, 2]


@pytest.mark.parametrize(
    "broken,message",
    [
        ({"schema": "other/1"}, "schema"),
        ({"mode": "stack"}, "do not match"),
        ({"arguments": None, "input": None, "version": None}, None),
        ({"preset": None, "seed": None}, None),
        ({"arguments": 3}, "arguments and input must be mappings"),
        ({"input": None}, "arguments and input must be mappings"),
        ({"input": {"name": None, "sha256": None}}, "input name must be a file name, got None"),
        ({"input": {"name": 5, "sha256": None}}, "input name must be a file name, got 5"),
        ({"input": {"name": "", "sha256": None}}, "input name must be a file name"),
        ({"input": {"name": "a.png", "sha256": 5}}, "input sha256 must be a hex digest"),
    ],
)
def test_a_bad_record_is_refused_by_name(broken, message):
    record = dict(_record(), **broken)
    if message is None:  # missing keys
        for key in broken:
            del record[key]
        message = "lacks"
    with pytest.raises(provenance.ProvenanceError, match=message):
        provenance.check(record)
    with pytest.raises(provenance.ProvenanceError):
        provenance.from_json(json.dumps(record))


def test_the_layer_metadata_is_a_record_of_the_same_schema():
    data = np.random.default_rng(0).integers(0, 256, (8, 9)).astype(np.uint8)
    plan = make_plan(LayerSnapshot.of(data, name="cell"), Choices(mode="stack"))
    record = plan.layer_kwargs["metadata"][METADATA_KEY]
    provenance.check(record)
    mode, arguments = provenance.reproduce_call(json.loads(json.dumps(record)))
    assert mode == "stack" and record["input"]["name"] == "cell"
    *_, result = api.labyrinth_steps(data, mode, **arguments)
    np.testing.assert_array_equal(result.image, api.labyrinth_stack(data, seed=0))


def test_a_record_from_before_the_noise_gate_reproduces_without_it():
    image = samples.smectic_batonnets((48, 48), seed=1)
    source = provenance.input_record("in.tif", image.shape, image.dtype, "0" * 64)
    record = provenance.rendering_record("single", {"preset": "labyrinth"}, source=source)
    assert record["arguments"]["noise_gate"] == resolve_parameters("labyrinth").noise_gate > 0
    del record["arguments"]["noise_gate"], record["parameters"]["noise_gate"]
    _, arguments = provenance.reproduce_call(record)
    assert arguments["noise_gate"] == 0.0
    np.testing.assert_array_equal(
        napari_labyrinth.labyrinth(image, **arguments),
        napari_labyrinth.labyrinth(image, noise_gate=0),
    )


def test_the_record_keeps_the_noise_each_plane_measured():
    image = samples.smectic_batonnets((48, 48), seed=1)
    rgba = np.stack([image, image, image, np.full_like(image, 255)], axis=-1)
    result = list(api.labyrinth_steps(rgba, channel_axis=-1))[-1]
    assert len(result.noise_sigma) == 1  # one luminance plane
    grey_alpha = np.stack([image, np.full_like(image, 255)])
    result = list(api.labyrinth_steps(grey_alpha, channel_axis=0, alpha=True))[-1]
    assert result.noise_sigma[0] > 0 and result.noise_sigma[1] is None  # alpha: not rendered
    source = provenance.input_record("in.tif", grey_alpha.shape, grey_alpha.dtype, None)
    record = provenance.rendering_record(
        "single", {"channel_axis": 0, "alpha": True}, source=source,
        noise_sigma=result.noise_sigma,
    )  # fmt: skip
    assert json.loads(json.dumps(record))["noise_sigma"] == [result.noise_sigma[0], None]
    assert "noise_sigma" not in provenance.rendering_record("single", {}, source=source)
