"""Numba kernels of tiled processing (private to `pointatlas.batch`)."""

from .pieces import smooth_pieces_kernel

__all__ = ["smooth_pieces_kernel"]
