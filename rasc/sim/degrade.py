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


# ------------------------------------------------------------ what real cameras show
# Each takes and returns a uint8 image; each is the identity at its "off" value, and
# :func:`rasc.sim.render.view_image` applies them in the order of a real camera: defocus
# (needs the render's depth), lens distortion, motion blur, Gaussian blur, vignetting,
# the sensor's shot and read noise, Gaussian pixel noise, JPEG compression.


def _check(value: float, name: str, lo: float, hi: float, unit: str) -> float:
    if not (np.isfinite(value) and lo <= value <= hi):
        raise InputError(f"{name} must be a number from {lo:g} to {hi:g} ({unit}), got {value}")
    return float(value)


def sensor_noise(image: np.ndarray, full_well: float, read_noise: float,
                 rng: np.random.Generator) -> np.ndarray:
    """The noise of a sensor that collects ``full_well`` electrons at grey level 255
    (gain ``full_well / 255`` e⁻ per grey level): each pixel's electrons
    (grey · full_well / 255) drawn from a Poisson law (shot noise: variance = signal),
    plus Gaussian read noise of ``read_noise`` electrons RMS, converted back to grey,
    rounded and clipped. ``full_well`` 0: the image unchanged (no draw)."""
    image = _image(image)
    if full_well == 0:
        return image.copy()
    _check(full_well, "full_well", 1.0, 1e7, "electrons")
    _check(read_noise, "read_noise", 0.0, 1e4, "electrons")
    gain = full_well / 255.0                      # electrons per grey level
    electrons = rng.poisson(image.astype(float) * gain).astype(float)
    if read_noise:
        electrons += rng.normal(0.0, read_noise, image.shape)
    return _to_uint8(electrons / gain)


def vignette(image: np.ndarray, strength: float) -> np.ndarray:
    """Radial fall-off of light: gain ``1 - strength * (r / r_corner)^2`` about the image
    centre (``strength`` = the fraction of light lost at the image corners, 0 to 0.95;
    the leading term of cos⁴ and of a lens's measured vignetting polynomial)."""
    image = _image(image)
    _check(strength, "vignetting", 0.0, 0.95, "fraction of light lost at the corners")
    if strength == 0:
        return image.copy()
    h, w = image.shape[:2]
    v, u = np.mgrid[0:h, 0:w].astype(float)
    cu, cv = (w - 1) / 2.0, (h - 1) / 2.0
    gain = 1.0 - strength * ((u - cu) ** 2 + (v - cv) ** 2) / (cu ** 2 + cv ** 2)
    if image.ndim == 3:
        gain = gain[..., None]
    return _to_uint8(image * gain)


def motion_kernel(length: float, angle_deg: float) -> np.ndarray:
    """The point-spread function of a straight motion of ``length`` pixels in the image
    direction ``angle_deg`` (0: along +u, 90: along +v), sampled finely and normalised
    to sum 1 (ends anti-aliased: a length of 2.5 px is not one of 2 or 3)."""
    half = int(np.ceil(length / 2.0)) + 1
    size = 2 * half + 1
    kernel = np.zeros((size, size))
    a = np.radians(angle_deg)
    steps = max(2, int(np.ceil(length * 16)))
    for t in (np.arange(steps) + 0.5) / steps - 0.5:     # the path, centred on the pixel
        x, y = half + t * length * np.cos(a), half + t * length * np.sin(a)
        x0, y0 = int(np.floor(x)), int(np.floor(y))
        fx, fy = x - x0, y - y0                          # bilinear splat of each sample
        kernel[y0, x0] += (1 - fx) * (1 - fy)
        kernel[y0, x0 + 1] += fx * (1 - fy)
        kernel[y0 + 1, x0] += (1 - fx) * fy
        kernel[y0 + 1, x0 + 1] += fx * fy
    return kernel / kernel.sum()


def motion_blur(image: np.ndarray, length: float, angle_deg: float = 0.0) -> np.ndarray:
    """Linear motion blur: the image convolved with :func:`motion_kernel` (``length``
    pixels along ``angle_deg``; the blur of a camera or target moving uniformly during
    the exposure). ``length`` 0: the image unchanged."""
    image = _image(image)
    _check(length, "motion_blur", 0.0, 50.0, "pixels")
    if not np.isfinite(angle_deg):
        raise InputError(f"motion_angle must be a finite number of degrees, got {angle_deg}")
    if length == 0:
        return image.copy()
    import cv2

    out = cv2.filter2D(image.astype(np.float32), -1,
                       motion_kernel(length, angle_deg).astype(np.float32),
                       borderType=cv2.BORDER_REPLICATE)
    return _to_uint8(out)


def jpeg(image: np.ndarray, quality: int) -> np.ndarray:
    """The image after JPEG compression at ``quality`` (1 to 100, OpenCV's
    ``IMWRITE_JPEG_QUALITY``) and decompression; 0: unchanged."""
    image = _image(image)
    if isinstance(quality, bool) or not isinstance(quality, (int, np.integer)) \
            or not 0 <= quality <= 100:
        raise InputError(f"jpeg_quality must be an integer from 1 to 100 (0: no JPEG), "
                         f"got {quality!r}")
    if quality == 0:
        return image.copy()
    import cv2

    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:          # pragma: no cover - OpenCV encodes any uint8 image
        raise InputError(f"jpeg_quality {quality}: OpenCV could not encode the image")
    flag = cv2.IMREAD_GRAYSCALE if image.ndim == 2 else cv2.IMREAD_COLOR
    return cv2.imdecode(data, flag).reshape(image.shape)


#: the largest circle of confusion :func:`defocus` draws (pixels, diameter); larger
#: ones are drawn at this size
MAX_COC_PX = 40.0
#: circles of confusion are drawn at this step of diameter (pixels) and blended
#: linearly between the two nearest steps
COC_STEP_PX = 0.5


def circle_of_confusion_px(depth_m: np.ndarray, fx_px: float, focal_length_mm: float,
                           f_number: float, focus_distance_m: float) -> np.ndarray:
    """Thin-lens circle of confusion (diameter, pixels) of points at ``depth_m`` (metres
    along the optical axis) for a lens of ``focal_length_mm`` at ``f_number`` focused at
    ``focus_distance_m``, on a sensor whose focal length in pixels is ``fx_px``:
    c = (f / N) · f / (s − f) · |d − s| / d in metres on the sensor, times the pixels per
    metre fx_px / f."""
    f = focal_length_mm * 1e-3
    s = focus_distance_m
    depth = np.maximum(np.asarray(depth_m, dtype=float), 1e-6)
    return fx_px * f / (f_number * (s - f)) * np.abs(depth - s) / depth


def disk_kernel(diameter: float) -> np.ndarray:
    """A uniform disk of ``diameter`` pixels (the defocus point-spread function of a round
    aperture), its edge pixels weighted by their covered area (8 x 8 samples), sum 1; a
    diameter below one pixel is a single pixel."""
    r = diameter / 2.0
    half = int(np.ceil(r))
    if r <= 0.5:
        return np.ones((1, 1))
    sub = (np.arange(8) + 0.5) / 8 - 0.5
    g = np.arange(-half, half + 1)
    x = (g[:, None] + sub[None, :]).ravel()
    inside = (x[:, None] ** 2 + x[None, :] ** 2) <= r * r
    n = 2 * half + 1
    kernel = inside.reshape(n, 8, n, 8).mean(axis=(1, 3))
    return kernel / kernel.sum()


def defocus(image: np.ndarray, coc_px: np.ndarray) -> np.ndarray:
    """Depth-dependent defocus: each pixel blurred by a disk of its own circle of
    confusion ``coc_px`` (H, W) (diameter, pixels; :func:`circle_of_confusion_px`).

    A gather by layers: the image is blurred with disks at steps of
    :data:`COC_STEP_PX` up to the largest circle present (at most :data:`MAX_COC_PX`),
    and each pixel takes the linear blend of the two layers around its own circle. At a
    depth edge this gathers, not scatters (a sharp foreground does not bleed over a
    blurred background): the usual post-process approximation, exact on a plane."""
    import cv2

    image = _image(image)
    coc = np.clip(np.asarray(coc_px, dtype=float), 0.0, MAX_COC_PX)
    if coc.shape != image.shape[:2]:
        raise InputError(f"defocus: circle-of-confusion map {coc.shape} is not the image's "
                         f"{image.shape[:2]}")
    level = coc / COC_STEP_PX
    top = int(np.ceil(level.max()))
    if top == 0:
        return image.copy()
    src = image.astype(np.float32)
    out = np.zeros(image.shape, dtype=float)
    lo = np.floor(level).astype(int)
    frac = level - lo
    if image.ndim == 3:
        lo, frac = lo[..., None], frac[..., None]
    for k in range(top + 1):
        w = np.where(lo == k, 1.0 - frac, 0.0) + np.where(lo == k - 1, frac, 0.0)
        if not w.any():
            continue
        layer = cv2.filter2D(src, -1, disk_kernel(k * COC_STEP_PX).astype(np.float32),
                             borderType=cv2.BORDER_REPLICATE)
        out += w * layer
    return _to_uint8(out)
