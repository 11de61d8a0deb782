"""The noise gate on the command line: its flag comes from the parameter table."""

import imageio.v3 as iio
import pytest

from napari_labyrinth import samples
from napari_labyrinth.cli import main
from napari_labyrinth.io import read_provenance


@pytest.mark.parametrize("value", ["-1", "nan", "1000", "two"])
def test_a_bad_noise_gate_is_refused_naming_it(tmp_path, capsys, value):
    path = tmp_path / "in.png"
    iio.imwrite(path, samples.smectic_batonnets((32, 32)))
    code = main(["render", str(path), "-o", str(tmp_path / "out.png"), "--noise-gate", value])
    assert code != 0 and not (tmp_path / "out.png").exists()
    assert "noise_gate" in capsys.readouterr().err


def test_the_record_keeps_the_gate_and_the_noise_it_measured(tmp_path):
    path = tmp_path / "in.tif"
    iio.imwrite(path, samples.smectic_batonnets((64, 64)))
    out = tmp_path / "out.tif"
    assert main(["render", str(path), "-o", str(out), "--noise-gate", "1.5"]) == 0
    record = read_provenance(out)
    assert record["arguments"]["noise_gate"] == 1.5 == record["parameters"]["noise_gate"]
    (sigma,) = record["noise_sigma"]
    assert sigma > 0
    assert main(["reproduce", str(out)]) == 0  # renders again and finds the same pixels
