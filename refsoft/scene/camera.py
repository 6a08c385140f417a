"""Cameras with OpenGL conventions (spec section 2).

World space is right-handed with y up; view space looks down -z. ``projection_matrix`` is the
classic ``gluPerspective`` (or ``glOrtho``) matrix, so clip coordinates, NDC and window depth are
exactly what an OpenGL port computes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .. import validate
from .. import constants
from .. import linalg
from ..errors import CameraError, LimitError


def _vec3(value, name: str) -> np.ndarray:
    if isinstance(value, np.ndarray) and value.dtype == np.float64 and not value.flags.writeable:
        arr = value  # already frozen (another camera's, through dataclasses.replace): shared as it is
    else:
        arr = np.array(value, dtype=np.float64)  # a copy: the camera's own, made read-only below
    if arr.shape != (3,):
        raise CameraError(f"camera {name} must be 3 numbers, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise CameraError(f"camera {name} is not finite: {arr.tolist()}")
    return arr


def check_image_size(width, height, what: str = "image") -> tuple[int, int]:
    """Validate an image size against the limits in :mod:`refsoft.constants`.

    Returns
    -------
    (int, int)
        ``(width, height)`` as Python ints.
    """
    for name, v in (("width", width), ("height", height)):
        if not validate.is_integer(v):
            raise CameraError(f"{what} {name} must be an integer, got {v!r}")
        if v <= 0:
            raise CameraError(f"{what} {name} must be positive, got {v}")
        if v > constants.MAX_IMAGE_EDGE:
            raise LimitError(f"{what} {name} {v} exceeds the limit of {constants.MAX_IMAGE_EDGE} pixels")
    if int(width) * int(height) > constants.MAX_IMAGE_PIXELS:
        raise LimitError(
            f"{what} of {width}x{height} pixels exceeds the limit of {constants.MAX_IMAGE_PIXELS} pixels"
        )
    return int(width), int(height)


@dataclass(frozen=True)
class Camera:
    """A pinhole (or orthographic) camera with OpenGL conventions.

    Parameters
    ----------
    eye, target, up : array_like, shape (3,)
        Position, look-at point and up hint in world space (kept as read-only float64 copies:
        a camera does not change; :func:`dataclasses.replace` or :meth:`widened` make another).
    fov_y : float
        Vertical field of view in degrees, in (0, 180) (perspective only).
    width, height : int
        Image size in pixels.
    near, far : float
        Clip plane distances, ``0 < near < far`` (orthographic: ``near < far``).
    projection : {"perspective", "orthographic"}
        Projection type.
    ortho_height : float
        Height of the view volume in world units (orthographic only).
    """

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray = (0.0, 1.0, 0.0)
    fov_y: float = 45.0
    width: int = 640
    height: int = 480
    near: float = 0.1
    far: float = 100.0
    projection: str = "perspective"
    ortho_height: float = 2.0

    def __post_init__(self):
        eye = _vec3(self.eye, "eye")
        target = _vec3(self.target, "target")
        up = _vec3(self.up, "up")
        for name, arr in (("eye", eye), ("target", target), ("up", up)):
            arr.flags.writeable = False  # frozen like the camera: its matrices are computed once
            object.__setattr__(self, name, arr)
        forward = target - eye
        if np.linalg.norm(forward) == 0.0:
            raise CameraError(f"camera eye equals target {eye.tolist()}")
        if np.linalg.norm(up) == 0.0:
            raise CameraError("camera up is the zero vector")
        f = forward / linalg.norm3(forward)
        u = up / linalg.norm3(up)
        if np.linalg.norm(np.cross(f, u)) < constants.CAMERA_PARALLEL_TOL:
            raise CameraError(f"camera up {up.tolist()} is parallel to the view direction")
        if self.projection not in ("perspective", "orthographic"):
            raise CameraError(f"camera projection must be 'perspective' or 'orthographic', got {self.projection!r}")
        for name in ("fov_y", "near", "far", "ortho_height"):
            v = getattr(self, name)
            if not validate.is_number(v):
                raise CameraError(f"camera {name} must be a finite number, got {v!r}")
            object.__setattr__(self, name, float(v))
        if self.projection == "perspective":
            if not 0.0 < self.fov_y < 180.0:
                raise CameraError(f"camera fov_y must be in (0, 180) degrees, got {self.fov_y}")
            if not 0.0 < self.near < self.far:
                raise CameraError(f"camera needs 0 < near < far, got near={self.near}, far={self.far}")
        else:
            if not self.near < self.far:
                raise CameraError(f"camera needs near < far, got near={self.near}, far={self.far}")
            if not self.ortho_height > 0.0:
                raise CameraError(f"camera ortho_height must be positive, got {self.ortho_height}")
        w, h = check_image_size(self.width, self.height, "camera")
        object.__setattr__(self, "width", w)
        object.__setattr__(self, "height", h)

    # ------------------------------------------------------------------ matrices
    @property
    def aspect(self) -> float:
        """``width / height``."""
        return self.width / self.height

    @property
    def forward(self) -> np.ndarray:
        """Unit view direction, shape (3,)."""
        d = self.target - self.eye
        return d / linalg.norm3(d)

    def view_matrix(self) -> np.ndarray:
        """World-to-view matrix (``gluLookAt``), shape (4, 4), float64."""
        f = self.forward
        s = np.cross(f, self.up)
        s /= linalg.norm3(s)
        u = np.cross(s, f)
        m = np.eye(4)
        m[0, :3] = s
        m[1, :3] = u
        m[2, :3] = -f
        m[:3, 3] = -linalg.matvec(m[:3, :3], self.eye)
        return m

    def projection_matrix(self) -> np.ndarray:
        """View-to-clip matrix (``gluPerspective`` or ``glOrtho``), shape (4, 4), float64."""
        n, f = self.near, self.far
        m = np.zeros((4, 4))
        if self.projection == "perspective":
            t = 1.0 / math.tan(math.radians(self.fov_y) / 2.0)
            m[0, 0] = t / self.aspect
            m[1, 1] = t
            m[2, 2] = (f + n) / (n - f)
            m[2, 3] = 2.0 * f * n / (n - f)
            m[3, 2] = -1.0
        else:
            top = self.ortho_height / 2.0
            right = top * self.aspect
            m[0, 0] = 1.0 / right
            m[1, 1] = 1.0 / top
            m[2, 2] = -2.0 / (f - n)
            m[2, 3] = -(f + n) / (f - n)
            m[3, 3] = 1.0
        return m

    def view_proj(self) -> np.ndarray:
        """World-to-clip matrix ``projection @ view``, shape (4, 4), float64 (a new array each
        call; computed once per camera)."""
        m = self.__dict__.get("_view_proj")
        if m is None:
            m = linalg.matmul(self.projection_matrix(), self.view_matrix())
            object.__setattr__(self, "_view_proj", m)
        return m.copy()

    def pixel_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space rays through every pixel centre (spec section 2 pixel convention).

        Returns
        -------
        origins : ndarray, shape (height, width, 3), float64
        directions : ndarray, shape (height, width, 3), float64, unit length
        """
        rows, cols = np.mgrid[0 : self.height, 0 : self.width]
        return self.rays(rows, cols)

    def rays(self, rows, cols) -> tuple[np.ndarray, np.ndarray]:
        """World-space rays through the centres of pixels ``(rows, cols)`` (row 0 at the top).

        Parameters
        ----------
        rows, cols : array_like of int, same shape S

        Returns
        -------
        origins : ndarray, shape S + (3,), float64
            The eye (perspective) or the point on the near plane (orthographic).
        directions : ndarray, shape S + (3,), float64, unit length
        """
        rows = np.asarray(rows, dtype=np.float64)
        cols = np.asarray(cols, dtype=np.float64)
        x_ndc = (cols + 0.5) / self.width * 2.0 - 1.0
        y_ndc = (self.height - rows - 0.5) / self.height * 2.0 - 1.0
        inv = linalg.inv(self.view_proj())
        ones = np.ones_like(x_ndc)
        shape = x_ndc.shape + (4,)
        near_pts = linalg.rows_times(np.stack([x_ndc, y_ndc, -ones, ones], axis=-1).reshape(-1, 4), inv).reshape(shape)
        far_pts = linalg.rows_times(np.stack([x_ndc, y_ndc, ones, ones], axis=-1).reshape(-1, 4), inv).reshape(shape)
        near_pts = near_pts[..., :3] / near_pts[..., 3:]
        far_pts = far_pts[..., :3] / far_pts[..., 3:]
        d = far_pts - near_pts
        d /= linalg.norm3(d)[..., None]
        if self.projection == "perspective":
            origins = np.broadcast_to(self.eye, d.shape).copy()
        else:
            origins = near_pts
        return origins, d

    def project(self, points) -> np.ndarray:
        """Project world points to window coordinates (GL: origin bottom-left, y up).

        Parameters
        ----------
        points : array_like, shape (N, 3)

        Returns
        -------
        ndarray, shape (N, 3), float64
            ``x_w, y_w, z_w`` (window depth in [0, 1] inside the frustum).
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        clip = linalg.homogeneous(p, self.view_proj())
        ndc = clip[:, :3] / clip[:, 3:]
        return np.c_[(ndc[:, 0] + 1.0) * 0.5 * self.width, (ndc[:, 1] + 1.0) * 0.5 * self.height,
                     0.5 * ndc[:, 2] + 0.5]

    def widened(self, factor: float, width: int | None = None, height: int | None = None) -> "Camera":
        """The wider-frustum camera of Estalella section 5.2: same eye and direction.

        Parameters
        ----------
        factor : float
            ``tan(fov'/2) = factor * tan(fov/2)``; ``1.0`` returns an equal camera.
        width, height : int, optional
            Resolution; default keeps the view's pixel density: ``ceil(factor * size)``.
            The vertical extent is ``factor`` times the view's; the horizontal one follows
            from the new aspect ratio.

        Returns
        -------
        Camera
        """
        if not validate.is_number(factor) or factor < 1.0:
            raise CameraError(f"widen factor must be a finite number >= 1, got {factor!r}")
        factor = float(factor)
        if width is None:
            width = int(math.ceil(self.width * factor))
        if height is None:
            height = int(math.ceil(self.height * factor))
        if self.projection == "orthographic":
            return replace(self, ortho_height=self.ortho_height * factor, width=width, height=height)
        fov = math.degrees(2.0 * math.atan(factor * math.tan(math.radians(self.fov_y) / 2.0)))
        return replace(self, fov_y=fov, width=width, height=height)
