"""Scripted counterparts of the paper's figures, written to ``docs/gallery/``.

Run with ``make gallery`` (or ``python benchmarks/gallery.py [--out DIR]``).
Prints the metrics behind each figure. The paper's own figures are lost; each
PNG here re-creates what its caption describes with this package's presets:

- Fig. 1/2: a portrait with the labyrinthine tiling following its contours;
- Fig. 3: three nearby variance thresholds (the paper: 47 %, 50 %, 53 %);
- Fig. 4: passes of the algorithm, with the per-pass edge-enhancement score
  plotted (the paper's edge-map look after many passes is not reproduced);
- Fig. 5: a branching structure (retinal vessels, for the paper's tree);
- and the liquid-crystal textures the package is made for.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from figures import labelled_grid  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _gray(image):
    from skimage import color, util

    return util.img_as_ubyte(color.rgb2gray(image)) if image.ndim == 3 else image


def _save(path: Path, image: np.ndarray) -> None:
    from skimage import io

    io.imsave(path, image, check_contrast=False)
    print(path)


def _describe(name, original, rendered):
    from napari_labyrinth import metrics

    values = metrics.describe(original, rendered)
    text = ", ".join(f"{k} {v:.3g}" for k, v in values.items())
    print(f"  {name}: changed {np.mean(rendered != original):.1%}, {text}")
    return values


def figure_1_portraits(out: Path) -> None:
    from skimage import data

    from napari_labyrinth import labyrinth

    portrait = _gray(data.astronaut())[0:320, 100:420]
    camera = data.camera()[40:360, 60:380]
    rows = []
    for name, image in (("astronaut", portrait), ("camera", camera)):
        literal = labyrinth(image, preset="paper")
        tiled = labyrinth(image)
        _describe(f"{name} paper", image, literal)
        _describe(f"{name} labyrinth", image, tiled)
        rows.append([image, literal, tiled])
    grid = labelled_grid(
        rows,
        column_labels=["input", 'preset "paper" (literal)', 'preset "labyrinth" (default)'],
        title="Fig. 1/2: the labyrinthine tiling follows eyes, brows, hair and outlines",
    )
    _save(out / "fig1-portrait.png", grid)


def figure_3_thresholds(out: Path) -> None:
    from skimage import data

    from napari_labyrinth import labyrinth, metrics, resolve_parameters

    face = _gray(data.astronaut())[60:188, 150:278]
    centre = resolve_parameters().variance_threshold
    values = [round(centre * f, 4) for f in (0.94, 1.0, 1.06)]  # as 47 / 50 / 53 %
    cells, labels = [face], ["input"]
    for value in values:
        rendered = labyrinth(face, variance_threshold=value)
        cover = metrics.labyrinth_cover(rendered)
        _describe(f"V={value}", face, rendered)
        cells.append(rendered)
        labels.append(f"V = {value:g} (cover {cover:.2f})")
    grid = labelled_grid(
        [cells],
        column_labels=labels,
        scale=3,
        title="Fig. 3: nearby variance thresholds give different tilings",
    )
    _save(out / "fig3-thresholds.png", grid)


def figure_4_passes(out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from skimage import data

    from napari_labyrinth import labyrinth_stack, metrics

    image = _gray(data.astronaut())[20:276, 120:376]
    passes = 8
    stack = labyrinth_stack(image, passes=passes)
    shown = (0, 1, 2, 4, 8)
    grid = labelled_grid(
        [[stack[k] for k in shown]],
        column_labels=["input"] + [f"{k} pass{'es' if k > 1 else ''}" for k in shown[1:]],
        title='Fig. 4: preset "labyrinth", pass after pass: the walls grow along the contours',
    )
    _save(out / "fig4-passes.png", grid)

    curves = {
        'preset "labyrinth"': stack,
        'preset "paper" (literal)': labyrinth_stack(image, preset="paper", passes=passes),
    }
    figure, axes = plt.subplots(figsize=(5.5, 3.2), dpi=100)
    for (label, frames), style in zip(curves.items(), ("o-", "s--")):
        scores = [metrics.edge_enhancement(image, frames[k]) for k in range(1, passes + 1)]
        print(f"  edge enhancement per pass, {label}:", " ".join(f"{s:.3f}" for s in scores))
        axes.plot(range(1, passes + 1), scores, style, label=label)
    axes.axhline(0, color="0.7", lw=0.8)
    axes.set_xlabel("passes")
    axes.set_ylabel("edge enhancement")
    axes.set_title("Correlation of the added texture with the input's edges", fontsize=10)
    axes.legend(frameon=False)
    figure.tight_layout()
    figure.savefig(out / "fig4-edge-score.png")
    plt.close(figure)
    print(out / "fig4-edge-score.png")


def figure_5_branches(out: Path) -> None:
    from skimage import data, transform, util

    retina = data.retina()[..., 1]  # vessels contrast best in the green channel
    retina = util.img_as_ubyte(transform.resize(retina, (480, 480), anti_aliasing=True))
    crop = retina[100:420, 80:400]
    rocket = _gray(data.rocket())[60:380, 120:440]
    _input_and_labyrinth(
        out / "fig5-branches.png",
        {"retina": crop, "rocket": rocket},
        "Fig. 5: main branches enhanced, small details suppressed",
    )


def figure_liquid_crystals(out: Path) -> None:
    from skimage import util

    from napari_labyrinth import samples

    textures = {
        "schlieren": samples.nematic_schlieren((320, 320), seed=0),
        "fingerprint": samples.cholesteric_fingerprint((320, 320), seed=0, pitch=24),
    }
    _input_and_labyrinth(
        out / "liquid-crystals.png",
        {name: util.img_as_ubyte(image) for name, image in textures.items()},
        "Liquid-crystal textures: nematic Schlieren and cholesteric fingerprint",
    )


def _input_and_labyrinth(path: Path, images: dict[str, np.ndarray], title: str) -> None:
    """One row per image: the input and its rendering with the default preset."""
    from napari_labyrinth import labyrinth

    rows = []
    for name, image in images.items():
        tiled = labyrinth(image)
        _describe(name, image, tiled)
        rows.append([image, tiled])
    grid = labelled_grid(rows, column_labels=["input", 'preset "labyrinth"'], title=title)
    _save(path, grid)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "gallery"))
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for make in (
        figure_1_portraits,
        figure_3_thresholds,
        figure_4_passes,
        figure_5_branches,
        figure_liquid_crystals,
    ):
        print(f"{make.__name__}:")
        make(out)


if __name__ == "__main__":
    main()
