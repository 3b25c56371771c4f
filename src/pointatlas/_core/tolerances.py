"""Numeric thresholds used across pointatlas, each with the reason it exists."""

#: A normal shorter than this is treated as zero length (cannot be normalised
#: without amplifying round-off to O(1) direction errors).
NORMAL_ZERO_LENGTH = 1e-12

#: Angles between normals below this are treated as exactly 0 (GUIDE C1):
#: arccos of a dot product of identical unit vectors can return ~1e-8 instead of 0.
ANGLE_ZERO = 1e-7

#: Relative tolerance for comparing squared distances when breaking ties in
#: k-nearest-neighbour queries: distances equal to within round-off are ties
#: and the smaller index wins (GUIDE conventions).
DISTANCE_TIE_RTOL = 0.0

#: How many offending indices an error message lists before "...".
MAX_LISTED_INDICES = 5
