"""Numba kernels of tiled processing (private to `pointatlas.batch`)."""

from .pieces import piece_tops_kernel, smooth_pieces_kernel

__all__ = ["piece_tops_kernel", "smooth_pieces_kernel"]
