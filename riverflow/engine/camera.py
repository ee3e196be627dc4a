"""Camera: a perspective view of the world, and the one module that imports pyrr.

Re-does the camera part of Proland's ``SceneNode``/``TerrainNode`` view handling
(``worldToScreen``, the camera-to-world matrix used to unproject new particles, reference §3.5).
Proland unprojected a new particle through the scene depth buffer ("bad depths retrieved for
particles on some viewpoints"); we only build the pixel's ray here (:meth:`Camera.screen_to_ray`)
and cast it on the CPU onto the terrain and water heightfields
(:func:`riverflow.kernels.raycast.cast_rays_onto_heightfield`).

Conventions (pinned by ``tests/engine/test_camera.py``):

* World: x east, y north, z up, metres. Screen: pixels, origin at the **bottom-left** corner
  (OpenGL's window convention), ``screen = (ndc * 0.5 + 0.5) * size_px``.
* :meth:`Camera.view_matrix`, :meth:`Camera.projection_matrix`, :meth:`Camera.view_projection`
  return pyrr matrices: float32 ``(4, 4)`` in pyrr's **row-vector** layout (translation in
  ``m[3, :3]``, ``clip_row = [x, y, z, 1] @ m``), so ``m.ravel()`` is exactly what a GLSL
  ``uniform mat4`` wants with ``transpose=False`` (pyglet: ``program["mvp"] = m.ravel()``).
* :meth:`Camera.matrices_for_kernels` returns float64 **column-vector** matrices
  (``clip = M @ [x, y, z, 1]``), the transpose of the above, for numba kernels.
* We use pyrr's *function* API (``pyrr.matrix44``) only: the ``Matrix44`` class reverses the
  order of ``*``, and its rotation builders turn the opposite way to pyrr's quaternions
  (ecosystem reference §4); mixing them is the classic bug. pyrr's sphere/quadratic helpers are
  broken under numpy 2 and are never called.

A viewport of zero size (a minimised window) is *empty*: projections use aspect 1, screen
positions are 0, every pixel's ray is the view direction; nothing is NaN.
"""
from __future__ import annotations

import math

import numpy as np
from pyrr import matrix44

_EPS = 1e-9


class Camera:
    """Perspective camera: plain state plus the matrices and projections derived from it.

    Every change to the view or the viewport increments :attr:`revision`, so systems can cache
    what depends on the view (``if camera.revision != self._seen: ...``).

    Args:
        position: eye (3,) [m].
        target: point looked at (3,) [m]; must differ from ``position``.
        up: world direction that should appear up on screen (3,); default +z.
        fov_y_deg: vertical field of view [degrees], in (0, 180).
        near_m, far_m: clip planes [m], 0 < near < far.
        size_px: viewport (W, H) [pixels]; (0, 0) is an empty viewport.
    """

    __slots__ = ("_position", "_target", "_up", "_forward", "_right", "_screen_up",
                 "_fov_y_deg", "_near_m", "_far_m", "_size_px", "revision",
                 "_kernel_matrices", "_host_matrices")

    def __init__(self, position=(0.0, -100.0, 50.0), target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0),
                 fov_y_deg: float = 60.0, near_m: float = 0.5, far_m: float = 10000.0,
                 size_px: tuple[int, int] = (0, 0)) -> None:
        self.revision = 0
        """Incremented by every change of view, projection or viewport."""
        self._kernel_matrices: tuple | None = None
        self._host_matrices: bytes | None = None
        self._forward = np.array([0.0, 1.0, 0.0])
        self._fov_y_deg = self._near_m = self._far_m = 0.0
        self._size_px = (0, 0)
        self.set_projection(fov_y_deg, near_m, far_m)
        self.set_viewport(*size_px)
        self.look_at(position, target, up)
        self.revision = 0

    # -- state ----------------------------------------------------------------------------

    @property
    def position(self) -> np.ndarray:
        """Eye (3,) float64 [m] (read-only view; change it with :meth:`look_at`)."""
        return self._position

    @position.setter
    def position(self, eye) -> None:
        self.look_at(eye, self._target, self._up)

    @property
    def target(self) -> np.ndarray:
        """Point looked at (3,) float64 [m] (read-only view)."""
        return self._target

    @target.setter
    def target(self, target) -> None:
        self.look_at(self._position, target, self._up)

    @property
    def up(self) -> np.ndarray:
        """Requested world up (3,) float64, unit (read-only view)."""
        return self._up

    @up.setter
    def up(self, up) -> None:
        self.look_at(self._position, self._target, up)

    @property
    def forward(self) -> np.ndarray:
        """Unit view direction (3,) float64."""
        return self._forward

    @property
    def right(self) -> np.ndarray:
        """Unit direction pointing to screen +x (3,) float64."""
        return self._right

    @property
    def screen_up(self) -> np.ndarray:
        """Unit direction pointing to screen +y (3,) float64 (``up`` made orthogonal)."""
        return self._screen_up

    @property
    def fov_y_deg(self) -> float:
        return self._fov_y_deg

    @fov_y_deg.setter
    def fov_y_deg(self, value: float) -> None:
        self.set_projection(value, self._near_m, self._far_m)

    @property
    def near_m(self) -> float:
        return self._near_m

    @near_m.setter
    def near_m(self, value: float) -> None:
        self.set_projection(self._fov_y_deg, value, self._far_m)

    @property
    def far_m(self) -> float:
        return self._far_m

    @far_m.setter
    def far_m(self, value: float) -> None:
        self.set_projection(self._fov_y_deg, self._near_m, value)

    @property
    def size_px(self) -> tuple[int, int]:
        """Viewport (W, H) [pixels]."""
        return self._size_px

    @size_px.setter
    def size_px(self, size: tuple[int, int]) -> None:
        self.set_viewport(*size)

    @property
    def is_empty(self) -> bool:
        """True when the viewport has no pixels (a minimised window)."""
        return self._size_px[0] <= 0 or self._size_px[1] <= 0

    @property
    def aspect(self) -> float:
        """Width / height; 1 for an empty viewport."""
        return 1.0 if self.is_empty else self._size_px[0] / self._size_px[1]

    # -- changes --------------------------------------------------------------------------

    def look_at(self, eye_xyz, target_xyz, up=(0.0, 0.0, 1.0)) -> None:
        """Put the eye at ``eye_xyz`` [m] looking at ``target_xyz`` [m] with ``up`` on top.

        When the view direction is parallel to ``up`` (looking straight down with up = +z) the
        screen's up is taken from the previous view's up direction projected out of the new
        view direction, else world +y (or +x). Each argument must be exactly 3 real numbers
        (shape (3,)): ``TypeError`` for text or non-numbers, ``ValueError`` (naming the
        argument) for another shape, NaN/inf, a zero ``up`` or ``eye == target``; the camera
        is then unchanged.
        """
        eye = _vec3(eye_xyz, "eye_xyz")
        target = _vec3(target_xyz, "target_xyz")
        up_v = _vec3(up, "up")
        forward = target - eye
        dist = float(np.linalg.norm(forward))
        up_len = float(np.linalg.norm(up_v))
        if dist <= _EPS:
            raise ValueError("look_at: eye and target coincide")
        if up_len <= _EPS:
            raise ValueError("look_at: up is zero")
        forward /= dist
        up_v = up_v / up_len
        right = _cross(forward, up_v)
        if np.linalg.norm(right) < 1e-6:
            previous = getattr(self, "_screen_up", None)
            for candidate in ([] if previous is None else [previous]) + [np.array([0.0, 1.0, 0.0]),
                                                                        np.array([1.0, 0.0, 0.0])]:
                right = _cross(forward, candidate)
                if np.linalg.norm(right) >= 1e-6:
                    break
        right /= np.linalg.norm(right)
        self._position, self._target, self._up = _frozen(eye), _frozen(target), _frozen(up_v)
        self._forward = _frozen(forward)
        self._right = _frozen(right)
        self._screen_up = _frozen(_cross(right, forward))
        self.revision += 1

    def set_viewport(self, width_px: int, height_px: int) -> None:
        """Resize the viewport [pixels]; negative sizes count as 0 (empty)."""
        self._size_px = (max(0, int(width_px)), max(0, int(height_px)))
        self.revision += 1

    def set_projection(self, fov_y_deg: float, near_m: float, far_m: float) -> None:
        """Field of view [degrees] and clip planes [m]; ``ValueError`` unless
        0 < fov < 180 and 0 < near < far (finite)."""
        fov, near, far = float(fov_y_deg), float(near_m), float(far_m)
        if not (0.0 < fov < 180.0 and 0.0 < near < far < math.inf):
            raise ValueError(f"bad projection: fov {fov} deg, near {near} m, far {far} m")
        self._fov_y_deg, self._near_m, self._far_m = fov, near, far
        self.revision += 1

    def set_matrices(self, view, projection) -> None:
        """Take a host's camera: its ``view`` (world → eye) and ``projection`` (eye → clip)
        matrices, each 16 numbers in OpenGL's **column-major** order (what
        ``glUniformMatrix4fv(..., GL_FALSE, m)`` reads: ``pyglet.math.Mat4``, PyGLM's
        ``mat4``, a pyrr matrix, or ``M.T`` / ``M.ravel(order="F")`` of a numpy (4, 4) ``M``
        written as in maths, ``clip = M @ [x, y, z, 1]``). World: x east, y north, z up [m].

        The view must be a rotation and a translation (no scale); the projection a symmetric
        perspective with OpenGL's depth range (−1 at the near plane, +1 at the far one: what
        ``glm.perspective`` and ``Mat4.perspective_projection`` make) whose aspect is the
        viewport's (``size_px``). The same matrices as last time change nothing (the camera's
        :attr:`revision` stays). Raises ``ValueError`` naming what does not fit."""
        v = _matrix16(view, "view")
        p = _matrix16(projection, "projection")
        key = v.tobytes() + p.tobytes()
        if key == self._host_matrices:
            return
        rotation = v[:3, :3]
        if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-4) \
                or not np.allclose(v[3], (0.0, 0.0, 0.0, 1.0), atol=1e-6):
            raise ValueError("set_matrices: view must be a rotation and a translation "
                             "(world → eye, no scale or projection); got rows "
                             f"{np.round(v, 4).tolist()}")
        sx, sy, a, b = p[0, 0], p[1, 1], p[2, 2], p[2, 3]
        off = [p[0, 1], p[0, 2], p[0, 3], p[1, 0], p[1, 2], p[1, 3], p[2, 0], p[2, 1],
               p[3, 0], p[3, 1], p[3, 3]]
        if not (sx > 0 and sy > 0 and abs(p[3, 2] + 1.0) < 1e-6
                and np.allclose(off, 0.0, atol=1e-6)):
            raise ValueError("set_matrices: projection must be a symmetric OpenGL perspective "
                             "(glm.perspective, Mat4.perspective_projection; column-major); "
                             f"got rows {np.round(p, 4).tolist()}")
        near, far = b / (a - 1.0), b / (a + 1.0)
        if not 0.0 < near < far < math.inf:
            raise ValueError(f"set_matrices: the projection's clip planes are near {near:g} m, "
                             f"far {far:g} m (need 0 < near < far; depth −1 at near, +1 at "
                             "far)")
        aspect = sy / sx
        if not self.is_empty and abs(aspect / self.aspect - 1.0) > 1e-3:
            raise ValueError(f"set_matrices: the projection's aspect {aspect:.4f} is not the "
                             f"viewport's {self.size_px[0]}/{self.size_px[1]} = "
                             f"{self.aspect:.4f}")
        eye = -rotation.T @ v[:3, 3]
        forward = -rotation[2]
        self.set_projection(math.degrees(2.0 * math.atan(1.0 / sy)), near, far)
        self.look_at(eye, eye + forward, rotation[1])
        self._host_matrices = key

    # -- matrices -------------------------------------------------------------------------

    def view_matrix(self, dtype=np.float32) -> np.ndarray:
        """World → eye matrix (4, 4), pyrr row-vector layout (``eye_row = [x,y,z,1] @ V``,
        translation in ``V[3, :3]``); ``V.ravel()`` is a GL mat4 uniform (transpose=False)."""
        return matrix44.create_look_at(self._position, self._position + self._forward,
                                       self._screen_up, dtype=dtype)

    def projection_matrix(self, dtype=np.float32) -> np.ndarray:
        """Eye → clip perspective matrix (4, 4), pyrr row-vector layout; ``P.ravel()`` equals
        ``pyglet.math.Mat4.perspective_projection(aspect, near, far, fov)`` and is a GL mat4
        uniform (transpose=False)."""
        return matrix44.create_perspective_projection(self._fov_y_deg, self.aspect, self._near_m,
                                                      self._far_m, dtype=dtype)

    def view_projection(self, dtype=np.float32) -> np.ndarray:
        """World → clip matrix ``V @ P`` (4, 4), pyrr row-vector layout
        (``clip_row = [x,y,z,1] @ VP``); ``VP.ravel()`` is GLSL's ``projection * view``."""
        return (self.view_matrix(np.float64) @ self.projection_matrix(np.float64)).astype(dtype)

    def matrices_for_kernels(self) -> tuple[np.ndarray, np.ndarray]:
        """(M, M_inv): C-contiguous float64 (4, 4) **column-vector** world → clip matrix
        (``clip = M @ [x, y, z, 1]``, the transpose of :meth:`view_projection`) and its
        inverse (clip → world, divide by w afterwards)."""
        cached = self._kernel_matrices
        if cached is not None and cached[0] == self.revision:
            return cached[1], cached[2]
        # the same matrices as pyrr's look_at and perspective projection (view_matrix,
        # projection_matrix: pinned by the tests), written out in plain floats from the basis
        # look_at already has, with the inverse in closed form (V⁻¹ = [Rᵀ | e], P⁻¹ is
        # sparse): a frame's camera then costs a few µs, not ~60 µs of small numpy calls
        (r0, r1, r2), (u0, u1, u2) = self._right.tolist(), self._screen_up.tolist()
        (f0, f1, f2), (e0, e1, e2) = self._forward.tolist(), self._position.tolist()
        sy = 1.0 / math.tan(math.radians(self._fov_y_deg) * 0.5)
        sx = sy / self.aspect
        near, far = self._near_m, self._far_m
        a = (far + near) / (near - far)
        b = 2.0 * far * near / (near - far)
        re = r0 * e0 + r1 * e1 + r2 * e2
        ue = u0 * e0 + u1 * e1 + u2 * e2
        fe = f0 * e0 + f1 * e1 + f2 * e2
        m = np.array([[sx * r0, sx * r1, sx * r2, -sx * re],
                      [sy * u0, sy * u1, sy * u2, -sy * ue],
                      [-a * f0, -a * f1, -a * f2, a * fe + b],
                      [f0, f1, f2, -fe]])
        ab = a / b
        inv = np.array([[r0 / sx, u0 / sy, e0 / b, f0 + ab * e0],
                        [r1 / sx, u1 / sy, e1 / b, f1 + ab * e1],
                        [r2 / sx, u2 / sy, e2 / b, f2 + ab * e2],
                        [0.0, 0.0, 1.0 / b, ab]])
        self._kernel_matrices = (self.revision, m, inv)
        return m, inv

    # -- projections ----------------------------------------------------------------------

    def world_to_screen(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Project world points.

        Args:
            points: (N, 3) [m].

        Returns:
            screen_px (N, 2) float64, origin bottom-left, ``(ndc.xy * 0.5 + 0.5) * size_px``;
            depth (N,) float64 NDC z (−1 at the near plane, +1 at the far plane);
            in_front (N,) bool, the point lies in front of the eye plane (clip w > 0).
            For points not in front, screen_px and depth are finite but meaningless.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        m, _ = self.matrices_for_kernels()
        clip = p @ m[:, :3].T + m[:, 3]
        w = clip[:, 3]
        in_front = w > 0.0
        w_safe = np.where(in_front, w, np.maximum(np.abs(w), 1e-12))
        ndc = clip[:, :3] / w_safe[:, None]
        size = np.array(self._size_px, dtype=np.float64)
        return (ndc[:, :2] * 0.5 + 0.5) * size, ndc[:, 2], in_front

    def screen_to_ray(self, screen_px) -> tuple[np.ndarray, np.ndarray]:
        """Rays through pixels (origin bottom-left, pixel centres at +0.5).

        Args:
            screen_px: (N, 2) [pixels].

        Returns:
            origin (N, 3) float64, the eye [m]; direction (N, 3) float64, unit. The inverse of
            :meth:`world_to_screen`: the ray through ``world_to_screen(p)`` passes through p.
            For an empty viewport every ray is the view direction.
        """
        s = np.asarray(screen_px, dtype=np.float64).reshape(-1, 2)
        if self.is_empty:
            ndc = np.zeros_like(s)
        else:
            ndc = 2.0 * s / np.array(self._size_px, dtype=np.float64) - 1.0
        tan_half = math.tan(math.radians(self._fov_y_deg) * 0.5)
        d = (self._forward + (ndc[:, :1] * tan_half * self.aspect) * self._right
             + (ndc[:, 1:] * tan_half) * self._screen_up)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return np.broadcast_to(self._position, d.shape).copy(), d


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of two 3-vectors (np.cross costs ~25 µs a call in its generic path)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def _vec3(v, name: str) -> np.ndarray:
    """``v`` as a (3,) float64 vector: exactly 3 real numbers (a (3,) array or sequence; not
    (1, 3), (3, 1) or text: TypeError / ValueError naming ``name``), all finite."""
    if isinstance(v, (str, bytes)):
        raise TypeError(f"look_at: {name} must be 3 finite numbers [m], got {v!r:.80}")
    try:
        a = np.asarray(v)
    except ValueError:                          # ragged sequences
        raise ValueError(f"look_at: {name} must be 3 finite numbers [m], got {v!r:.80}") \
            from None
    if a.dtype.kind not in "fiu":             # not bool, complex, text or objects
        raise TypeError(f"look_at: {name} must be 3 real numbers [m], got {v!r:.80}")
    if a.shape != (3,):
        raise ValueError(f"look_at: {name} must be 3 finite numbers [m] (shape (3,)), got "
                         f"shape {a.shape}")
    a = a.astype(np.float64)                  # a copy, always
    if not np.isfinite(a).all():
        raise ValueError(f"look_at: {name} must be 3 finite numbers [m], got {a.tolist()}")
    return a


def _matrix16(m, name: str) -> np.ndarray:
    """16 numbers in OpenGL's column-major order as a float64 (4, 4) matrix written as in
    maths (``clip = M @ [x, y, z, 1]``); ValueError naming ``name`` otherwise."""
    try:
        a = np.asarray(m, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        a = np.asarray(list(m), dtype=np.float64).reshape(-1)   # Mat4 and other sequences
    if a.size != 16 or not np.isfinite(a).all():
        raise ValueError(f"set_matrices: {name} must be 16 finite numbers (a 4 × 4 matrix in "
                         f"OpenGL's column-major order), got {a.size} values")
    return a.reshape(4, 4).T.copy()


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.flags.writeable = False
    return a
