"""Image degradation applied to renders for realism: lens distortion, blur, pixel noise
(numpy/scipy only; :mod:`rasc.sim.scene` re-exports these names)."""

from __future__ import annotations

import numpy as np

from rasc.errors import InputError


def _image(image: np.ndarray, name: str = "image") -> np.ndarray:
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim not in (2, 3):
        raise InputError(f"{name}: expected a uint8 image (H, W) or (H, W, C), got "
                         f"{image.dtype} {image.shape}")
    return image


def _to_uint8(a: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(a), 0, 255).astype(np.uint8)


def add_pixel_noise(image: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Add Gaussian noise of ``sigma`` grey levels to every pixel, round and clip to uint8."""
    image = _image(image)
    if not (np.isfinite(sigma) and sigma >= 0):
        raise InputError(f"noise sigma must be >= 0 grey levels, got {sigma}")
    return _to_uint8(image + rng.normal(0.0, sigma, image.shape))


def blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur of ``sigma`` pixels in both image axes (not across channels), uint8."""
    image = _image(image)
    if not (np.isfinite(sigma) and sigma >= 0):
        raise InputError(f"blur sigma must be >= 0 pixels, got {sigma}")
    if sigma == 0:
        return image.copy()
    from scipy.ndimage import gaussian_filter

    sigmas = (sigma, sigma) + (0,) * (image.ndim - 2)
    return _to_uint8(gaussian_filter(image.astype(float), sigmas, mode="nearest"))


def distortion_warp(K: np.ndarray, dist, size: tuple[int, int]):
    """The warp of :func:`distort` for one camera, its remap computed once.

    Returns ``warp(image) -> image`` for images of ``size`` (width, height); the remap
    costs ~0.8 s at 1280×960, the warp itself ~0.03 s, so a renderer builds it once per
    camera.
    """
    from scipy.ndimage import map_coordinates

    from rasc.geometry.lens import distortion_remap

    map_x, map_y = distortion_remap(K, dist, size)
    coords = np.stack([map_y.astype(float), map_x.astype(float)])

    def warp(image: np.ndarray) -> np.ndarray:
        image = _image(image)
        channels = image[..., None] if image.ndim == 2 else image
        out = np.stack([map_coordinates(channels[..., c].astype(float), coords, order=1,
                                        mode="constant", cval=0.0)
                        for c in range(channels.shape[2])], axis=-1)
        return _to_uint8(out.reshape(image.shape))

    return warp


def distort(image: np.ndarray, K: np.ndarray, dist) -> np.ndarray:
    """Warp an ideal render into the image of a camera with lens distortion ``dist``.

    A point whose ideal projection (pinhole ``K``) is ``uv`` lands at
    ``rasc.geometry.lens.project_points`` with ``dist`` (OpenCV model, same ``K``). Bilinear
    interpolation; pixels whose ray falls outside the render are black.
    """
    image = _image(image)
    h, w = image.shape[:2]
    return distortion_warp(K, dist, (w, h))(image)


def degrade(image: np.ndarray, rng: np.random.Generator, *, K: np.ndarray | None = None,
            dist=None, blur_sigma: float = 0.0, noise_sigma: float = 0.0) -> np.ndarray:
    """Lens distortion (if ``dist`` has a non-zero term; needs ``K``), then blur, then noise."""
    image = _image(image)
    if dist is not None and np.any(np.asarray(dist, dtype=float) != 0):
        if K is None:
            raise InputError("degrade: lens distortion needs the camera matrix K")
        image = distort(image, K, dist)
    if blur_sigma:
        image = blur(image, blur_sigma)
    if noise_sigma:
        image = add_pixel_noise(image, noise_sigma, rng)
    return image
