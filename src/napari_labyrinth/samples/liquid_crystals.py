"""Synthetic liquid-crystal textures as seen between crossed polarisers: nematic Schlieren,
cholesteric fingerprints (dark and bright field) and smectic bâtonnets."""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import numpy as np

from ._shared import (
    _box,
    _is_finite_real,
    _spread_points,
    _validate_defects,
    _validate_noise,
    _validate_retardance,
    _validate_seed,
    _validate_shape,
    _zero_sum_strengths,
)

#: Strengths a seeded defect may take (topological charges of a nematic).
DEFECT_STRENGTHS = (-1.0, -0.5, 0.5, 1.0)


def schlieren_defects(
    shape: tuple[int, int] = (512, 512),
    *,
    seed: int = 0,
    count: int | None = None,
) -> np.ndarray:
    """Seeded positions and strengths of the defects of :func:`nematic_schlieren`.

    Parameters
    ----------
    shape : (int, int), optional
        Image shape ``(rows, columns)``.
    seed : int, optional
        Seed of the random generator.
    count : int, optional
        Number of defects (>= 2). Default: about one per 180 x 180 pixels
        (4 to 10), chosen by the seed.

    Returns
    -------
    defects : (count, 3) float64 ndarray
        Rows ``(y, x, strength)``: position in pixels and strength in
        {-1, -1/2, +1/2, +1}. The strengths add up to zero.
    """
    rows, columns = _validate_shape(shape)
    rng = np.random.default_rng(_validate_seed(seed))
    if count is None:
        typical = rows * columns / 180.0**2
        count = int(np.clip(np.rint(typical * rng.uniform(0.6, 1.2)), 4, 10))
    elif not isinstance(count, numbers.Integral) or isinstance(count, bool) or count < 2:
        raise ValueError(f"count of defects must be an integer >= 2, got {count!r}")
    count = int(count)
    strengths = _zero_sum_strengths(rng, count)
    positions = _spread_points(rng, count, rows, columns)
    return np.column_stack([positions, strengths])


def nematic_schlieren(
    shape: tuple[int, int] = (512, 512),
    *,
    seed: int = 0,
    defects: int | Sequence[Sequence[float]] | np.ndarray | None = None,
    noise: float = 0.03,
    retardance: float | np.ndarray | None = None,
    theta0: float | None = None,
) -> np.ndarray:
    r"""Synthetic Schlieren texture of a nematic film between crossed polarisers.

    Parameters
    ----------
    shape : (int, int), optional
        Image shape ``(rows, columns)``.
    seed : int, optional
        Seed of the random generator: it sets the defects (unless given), the
        uniform far-field angle and the noise. The same seed gives the same
        image.
    defects : int or (n, 3) array_like, optional
        ``None`` (default) or a count: seeded defects from
        :func:`schlieren_defects`, whose strengths add up to zero. Otherwise
        rows ``(y, x, strength)`` in pixels, each strength a non-zero multiple
        of 1/2 (half-integer strengths are what a nematic allows).
    noise : float, optional
        Standard deviation of the Gaussian noise added to the intensity
        (``0`` for none).
    retardance : float or ndarray, optional
        Optical retardance ``Delta n d / lambda`` of the film in wavelengths:
        a scalar or a field broadcastable to ``shape`` (e.g. a smooth
        thickness variation). The intensity is multiplied by
        ``sin^2(pi * retardance)``. ``None`` (default) leaves that factor
        out, i.e. a half-wave film.
    theta0 : float, optional
        Uniform director angle far from the defects, in radians from the
        first polariser. Default: drawn from the seed.

    Returns
    -------
    image : (rows, columns) float32 ndarray
        Intensity, clipped to [0, 1].

    Notes
    -----
    In a thin nematic film the director (the mean direction of the
    molecules) lies in the plane of the film at an angle :math:`\theta(x, y)`.
    In the one-constant approximation of elastic theory a point defect of
    strength :math:`s` at :math:`(x_k, y_k)` is
    :math:`\theta = s\,\mathrm{atan2}(y - y_k, x - x_k)`, and since the
    equilibrium equation :math:`\nabla^2 \theta = 0` is linear, defects
    superpose:

    .. math::

        \theta(x, y) = \theta_0 + \sum_k s_k \, \mathrm{atan2}(y - y_k, x - x_k).

    Going once around a defect turns the director by :math:`2\pi s`; because
    the director is a headless line, :math:`s` may be half an integer. Making
    the strengths add up to zero keeps the director uniform
    (:math:`\theta_0`) far from the defects, as for a film whose total charge
    is neutral.

    Between crossed polarisers (along x and y) a birefringent film of phase
    retardance :math:`\delta = 2\pi\,\Delta n\, d / \lambda` transmits

    .. math::

        I = \sin^2(2\theta) \, \sin^2(\delta / 2)
          = \sin^2(2\theta) \, \sin^2(\pi \cdot \mathrm{retardance}),

    which vanishes where the director is parallel to either polariser
    (:math:`\theta = n\pi/2`). Around a defect of strength :math:`s` the
    angle :math:`2\theta` turns by :math:`4\pi s`, so :math:`4|s|` dark
    brushes meet there: two at a :math:`\pm 1/2` defect, four at a
    :math:`\pm 1` defect. Brushes of positive defects turn with the
    polarisers, those of negative defects against them, and brushes join
    defects of opposite sign, which is the Schlieren texture (Frank, 1958;
    de Gennes & Prost, 1993, Sec. 4.2).

    References
    ----------
    .. [1] F. C. Frank, "On the theory of liquid crystals", Discuss. Faraday
           Soc. 25, 19-28 (1958).
    .. [2] P.-G. de Gennes and J. Prost, *The Physics of Liquid Crystals*,
           2nd ed., Oxford University Press (1993).

    Examples
    --------
    >>> from napari_labyrinth.samples import nematic_schlieren
    >>> image = nematic_schlieren((256, 256), seed=3)
    >>> image.shape, image.dtype
    ((256, 256), dtype('float32'))
    >>> bool(image.min() >= 0 and image.max() <= 1)
    True
    """
    rows, columns = _validate_shape(shape)
    seed = _validate_seed(seed)
    noise = _validate_noise(noise)
    if defects is None or (
        isinstance(defects, numbers.Integral) and not isinstance(defects, bool)
    ):
        table = schlieren_defects((rows, columns), seed=seed, count=defects)
    else:
        table = _validate_defects(defects)
    # An independent stream for theta_0 and the noise: changing the defects
    # does not change the rest.
    rng = np.random.default_rng([seed, 1])
    drawn_theta0 = rng.uniform(0.0, np.pi)  # drawn anyway: the noise stays the same
    if theta0 is None:
        theta0 = drawn_theta0
    elif not _is_finite_real(theta0):
        raise TypeError(f"theta0 must be a finite real number, got {theta0!r}")
    theta = director_angle((rows, columns), table, theta0=theta0)
    intensity = np.sin(2.0 * theta) ** 2
    if retardance is not None:
        intensity = (
            intensity * np.sin(np.pi * _validate_retardance(retardance, (rows, columns))) ** 2
        )
    if noise:
        intensity = intensity + rng.normal(0.0, noise, size=(rows, columns))
    return np.clip(intensity, 0.0, 1.0).astype(np.float32)


def director_angle(
    shape: tuple[int, int],
    defects: np.ndarray,
    *,
    theta0: float = 0.0,
) -> np.ndarray:
    """Director angle of superposed point defects (see :func:`nematic_schlieren`).

    Parameters
    ----------
    shape : (int, int)
        Image shape ``(rows, columns)``.
    defects : (n, 3) array_like
        Rows ``(y, x, strength)``.
    theta0 : float, optional
        Uniform angle added everywhere (radians).

    Returns
    -------
    theta : (rows, columns) float64 ndarray
        ``theta0 + sum_k s_k atan2(y - y_k, x - x_k)`` in radians, not wrapped.
    """
    rows, columns = _validate_shape(shape)
    table = np.asarray(defects, dtype=np.float64).reshape(-1, 3)
    y = np.arange(rows, dtype=np.float64)[:, None]
    x = np.arange(columns, dtype=np.float64)[None, :]
    theta = np.full((rows, columns), float(theta0))
    for y_k, x_k, s_k in table:
        theta += s_k * np.arctan2(y - y_k, x - x_k)
    return theta


def cholesteric_fingerprint(
    shape: tuple[int, int] = (512, 512),
    *,
    seed: int = 0,
    pitch: float = 16.0,
    noise: float = 0.03,
) -> np.ndarray:
    """Synthetic fingerprint texture of a cholesteric with its helix in the plane.

    Parameters
    ----------
    shape : (int, int), optional
        Image shape ``(rows, columns)``.
    seed : int, optional
        Seed of the random generator; the same seed gives the same image.
    pitch : float, optional
        Cholesteric pitch p in pixels (>= 4). The stripes repeat every p/2,
        the distance over which the director turns by 180 degrees.
    noise : float, optional
        Standard deviation of the Gaussian noise added to the intensity.

    Returns
    -------
    image : (rows, columns) float32 ndarray
        Intensity, clipped to [0, 1].

    Notes
    -----
    When the helix axis of a cholesteric lies in the plane of the film, the
    director alternates between in-plane and out-of-plane orientations every
    half pitch, which the microscope shows as bright and dark stripes of
    period p/2. The helix axis varies smoothly from place to place, so the
    stripes bend into the fingerprint-like, labyrinthine pattern, with
    dislocations where stripes end.

    The pattern relaxes as in a Swift-Hohenberg model, whose stationary
    states are such stripes: seeded white noise is passed a few times through
    a band-pass filter centred on the stripe wave number ``2 / p`` (cycles
    per pixel) with a saturating nonlinearity (``tanh``) in between, which
    selects one stripe period. The filter only passes wave vectors within
    about 30 degrees of a smooth, seeded helix-axis field, so the stripes
    follow it; a last band-pass gives them a smooth profile.

    References
    ----------
    .. [1] J. Swift and P. C. Hohenberg, "Hydrodynamic fluctuations at the
           convective instability", Phys. Rev. A 15, 319 (1977).
    .. [2] P.-G. de Gennes and J. Prost, *The Physics of Liquid Crystals*,
           2nd ed., Oxford University Press (1993), Ch. 6.

    Examples
    --------
    >>> from napari_labyrinth.samples import cholesteric_fingerprint
    >>> cholesteric_fingerprint((128, 128), pitch=12).shape
    (128, 128)
    """
    rows, columns = _validate_shape(shape)
    seed = _validate_seed(seed)
    noise = _validate_noise(noise)
    if not _is_finite_real(pitch):
        raise TypeError(f"pitch must be a finite real number, got {pitch!r}")
    if pitch < 4:
        raise ValueError(f"pitch must be >= 4 pixels, got {pitch!r}")
    return _fingerprint((rows, columns), seed, float(pitch), noise).astype(np.float32)


def smectic_batonnets(
    shape: tuple[int, int] = (512, 512), *, seed: int = 0, count: int | None = None
) -> np.ndarray:
    """Bright smectic bâtonnets in a dark isotropic melt, between crossed polarisers.

    Parameters
    ----------
    shape : (int, int), optional
        Image shape ``(rows, columns)``.
    seed : int, optional
        Seed of the random generator; the same seed gives the same image.
    count : int, optional
        Number of bâtonnets (>= 1). Default: about one per 60 x 60 pixels.

    Returns
    -------
    image : (rows, columns) uint8 ndarray
        A near-black background (tones 2-6 with camera noise) and bright
        rods of tones 120-250 with focal-conic stripes along them.

    Notes
    -----
    On cooling from the isotropic phase, a smectic A nucleates as elongated
    germs (bâtonnets) that are birefringent and shine between crossed
    polarisers while the isotropic melt around them stays black. Each rod is
    an ellipse of seeded length, width and orientation with a soft edge, its
    brightness modulated by stripes across its long axis; the camera adds a
    dark offset, shot noise and read noise.

    Examples
    --------
    >>> from napari_labyrinth.samples import smectic_batonnets
    >>> image = smectic_batonnets((128, 128))
    >>> image.dtype, int(np.median(image)) < 10
    (dtype('uint8'), True)
    """
    rows, columns = _validate_shape(shape)
    rng = np.random.default_rng(_validate_seed(seed))
    if count is None:
        count = max(1, int(round(rows * columns / 60.0**2)))
    elif not isinstance(count, numbers.Integral) or isinstance(count, bool) or count < 1:
        raise ValueError(f"count of batonnets must be an integer >= 1, got {count!r}")
    light = np.zeros((rows, columns))
    for _ in range(int(count)):
        cy, cx = rng.uniform(0, rows), rng.uniform(0, columns)
        length, width = rng.uniform(12, 40), rng.uniform(3, 8)
        angle = rng.uniform(0, np.pi)
        period = rng.uniform(5, 9)
        brightness = rng.uniform(0.5, 1.0)
        box = _box(cy, cx, length + 4, rows, columns)  # the rod and its soft edge
        y, x = np.mgrid[box].astype(np.float64)
        along = (x - cx) * np.cos(angle) + (y - cy) * np.sin(angle)
        across = -(x - cx) * np.sin(angle) + (y - cy) * np.cos(angle)
        inside = np.hypot(along / length, across / width)
        body = 1.0 / (1.0 + np.exp(np.minimum((inside - 1.0) * 12.0, 50.0)))  # soft edge
        stripes = 0.75 + 0.25 * np.cos(2 * np.pi * along / period)
        light[box] = np.maximum(light[box], body * stripes * brightness)
    photons = 4.0 + 240.0 * light
    counts = rng.poisson(photons).astype(np.float64) + rng.normal(0.0, 1.5, light.shape)
    return np.clip(np.rint(counts), 0, 255).astype(np.uint8)


def bright_fingerprint(
    shape: tuple[int, int] = (512, 512), *, seed: int = 0, pitch: float = 14.0
) -> np.ndarray:
    """A cholesteric fingerprint in bright field: low contrast on a bright background.

    Parameters
    ----------
    shape : (int, int), optional
        Image shape ``(rows, columns)``.
    seed : int, optional
        Seed of the random generator; the same seed gives the same image.
    pitch : float, optional
        Cholesteric pitch in pixels (>= 4), as for :func:`cholesteric_fingerprint`.

    Returns
    -------
    image : (rows, columns) uint8 ndarray
        Stripes between tones about 185 and 230 under a smooth illumination
        gradient, with camera noise.

    Examples
    --------
    >>> from napari_labyrinth.samples import bright_fingerprint
    >>> image = bright_fingerprint((128, 128))
    >>> bool(image.min() > 150)
    True
    """
    rows, columns = _validate_shape(shape)
    seed = _validate_seed(seed)
    stripes = cholesteric_fingerprint((rows, columns), seed=seed, pitch=pitch, noise=0.0)
    rng = np.random.default_rng(seed + 1)
    y, x = np.mgrid[0:rows, 0:columns] / max(rows, columns)
    illumination = 1.0 - 0.06 * ((y - 0.4) ** 2 + (x - 0.6) ** 2)
    tones = illumination * (188.0 + 40.0 * stripes) + rng.normal(0.0, 2.0, stripes.shape)
    return np.clip(np.rint(tones), 0, 255).astype(np.uint8)


def _fingerprint(shape: tuple[int, int], seed: int, pitch: float, noise: float) -> np.ndarray:
    """Body of :func:`cholesteric_fingerprint` (arguments validated)."""
    from math import comb

    from scipy import fft, ndimage

    rng = np.random.default_rng(seed)
    period = pitch / 2.0
    k0 = 1.0 / period  # cycles per pixel
    correlation = 7.0 * period  # length over which the helix axis turns
    # Pad (the FFTs are periodic) so that no seam shows at the border.
    pad = min(int(np.ceil(correlation)), max(shape))
    rows = fft.next_fast_len(shape[0] + 2 * pad, real=True)
    columns = fft.next_fast_len(shape[1] + 2 * pad, real=True)

    # Helix-axis direction psi: half the phase of a smooth complex field, so
    # that it has the +-1/2 disclinations a headless direction may have.
    z = ndimage.gaussian_filter(
        rng.standard_normal((2, rows, columns)), (0, correlation, correlation), mode="wrap"
    )
    psi = 0.5 * np.arctan2(z[1], z[0])

    # Band-pass filter around k0 with an angular window cos^(2m) centred on
    # psi(x). The window is steerable: a sum of 2m + 1 fixed filters
    # cos(2n theta), sin(2n theta) weighted by cos(2n psi), sin(2n psi).
    m = 3
    k_rows = np.fft.fftfreq(rows)[:, None]
    k_columns = np.fft.rfftfreq(columns)[None, :]
    radial = np.exp(-0.5 * ((np.hypot(k_rows, k_columns) - k0) / (0.15 * k0)) ** 2)
    theta = np.arctan2(k_rows, k_columns)
    filters, weights = [radial * comb(2 * m, m) / 4**m], [None]
    for n in range(1, m + 1):
        c = 2.0 * comb(2 * m, m - n) / 4**m
        filters += [c * radial * np.cos(2 * n * theta), c * radial * np.sin(2 * n * theta)]
        weights += [np.cos(2 * n * psi), np.sin(2 * n * psi)]

    def band_pass(u: np.ndarray) -> np.ndarray:
        spectrum = fft.rfft2(u)
        out = np.zeros_like(u)
        for f, w in zip(filters, weights, strict=True):
            filtered = fft.irfft2(spectrum * f, s=u.shape)
            out += filtered if w is None else w * filtered
        return out

    # Swift-Hohenberg-like relaxation: band-pass, saturate, repeat.
    u = rng.standard_normal((rows, columns))
    for _ in range(8):
        u = band_pass(u)
        u = np.tanh(2.5 * u / (u.std() + 1e-12))
    u = band_pass(u)[pad : pad + shape[0], pad : pad + shape[1]]
    u /= np.percentile(np.abs(u), 99) + 1e-12
    intensity = 0.5 + 0.5 * np.tanh(1.5 * u)
    if noise:
        intensity += np.random.default_rng([seed, 1]).normal(0.0, noise, shape)
    return np.clip(intensity, 0.0, 1.0)
