"""Synthetic test shapes with exact normals, mesh sampling and noise (docs/decisions/synth.md)."""

from ..io import vertex_normals  # the one implementation, re-exported for synth users
from ._clouds import MeshClouds, clouds_from_mesh, sphere_density, vertex_curvature
from ._mesh import SynthMesh, face_areas
from ._noise import add_gaussian_noise, add_normal_noise
from ._polyhedra import cube, dodecahedron, octahedron
from ._sample import MeshSample, sample_mesh
from ._shapes import (
    cylinder,
    fibonacci_sphere,
    icosphere,
    line,
    plane_patch,
    sphere,
    torus,
)

__all__ = [
    "MeshClouds",
    "MeshSample",
    "SynthMesh",
    "add_gaussian_noise",
    "add_normal_noise",
    "clouds_from_mesh",
    "cube",
    "cylinder",
    "dodecahedron",
    "face_areas",
    "fibonacci_sphere",
    "icosphere",
    "line",
    "octahedron",
    "plane_patch",
    "sample_mesh",
    "sphere",
    "sphere_density",
    "torus",
    "vertex_curvature",
    "vertex_normals",
]
