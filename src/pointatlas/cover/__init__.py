"""Ball covers of space and clouds cut from points (thesis 2.2, Props 4-5, Algorithm 2).

Layer 3; builds its cloud complexes with `pointatlas.complex`.
"""

from ._cover import BallCover, ball_cover, cover_radii, random_offsets, random_rotations
from ._search import ScaleSearch, search_cover_scale

__all__ = [
    "BallCover",
    "ScaleSearch",
    "ball_cover",
    "cover_radii",
    "random_offsets",
    "random_rotations",
    "search_cover_scale",
]
