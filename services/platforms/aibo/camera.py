"""The ERS-7 nose camera: 208x160 pixels, 56.9 x 45.2 degrees, rendered by PyBullet's tiny renderer.

The tiny renderer runs on the CPU with no window, so frames are the same with or without a GUI
and across machines. Shadows and specular highlights are off: both cost time, and highlights
wash the colour out of the balls, which perception needs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet

WIDTH, HEIGHT = 208, 160
VERTICAL_FOV_DEG = 45.2  # gives 56.9 degrees across at 208/160 aspect, the ERS-7's figures


@dataclass(frozen=True)
class NoseCamera:
    width: int = WIDTH
    height: int = HEIGHT
    vertical_fov_deg: float = VERTICAL_FOV_DEG
    near: float = 0.01
    far: float = 6.0
    light_direction: tuple[float, float, float] = (0.4, 0.3, 1.0)

    def view_matrix(self, position, orientation) -> list[float]:
        """Looking along the nose link's +x, with its +z up (column-major 4x4, OpenGL style)."""
        rotation = np.array(pybullet.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        eye = np.asarray(position, dtype=np.float64)
        return list(pybullet.computeViewMatrix(eye.tolist(), (eye + rotation[:, 0]).tolist(), rotation[:, 2].tolist()))

    def projection_matrix(self) -> list[float]:
        return list(pybullet.computeProjectionMatrixFOV(self.vertical_fov_deg, self.width / self.height, self.near,
                                                        self.far))

    def render(self, client, position, orientation) -> np.ndarray:
        """RGB uint8 image, shape (height, width, 3), row 0 at the top."""
        _, _, rgba, _, _ = client.getCameraImage(
            self.width, self.height, self.view_matrix(position, orientation), self.projection_matrix(),
            lightDirection=list(self.light_direction), shadow=0, lightAmbientCoeff=0.55,
            lightDiffuseCoeff=0.5, lightSpecularCoeff=0.0, renderer=pybullet.ER_TINY_RENDERER,
            flags=pybullet.ER_NO_SEGMENTATION_MASK)
        return np.asarray(rgba, dtype=np.uint8).reshape(self.height, self.width, 4)[:, :, :3].copy()


def project(view: list[float], projection: list[float], point, width: int = WIDTH,
            height: int = HEIGHT) -> np.ndarray | None:
    """Pixel (x right, y down; pixel centres at .5) where a world point lands, or None if behind the camera."""
    view_m = np.asarray(view, dtype=np.float64).reshape(4, 4).T  # pybullet matrices are column-major
    proj_m = np.asarray(projection, dtype=np.float64).reshape(4, 4).T
    clip = proj_m @ view_m @ np.append(np.asarray(point, dtype=np.float64), 1.0)
    if clip[3] <= 0:
        return None
    ndc = clip[:3] / clip[3]
    return np.array([(ndc[0] + 1.0) / 2.0 * width, (1.0 - ndc[1]) / 2.0 * height])
