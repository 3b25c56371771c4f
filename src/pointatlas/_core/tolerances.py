"""Numeric thresholds used across pointatlas, each with the reason it exists."""

#: A normal shorter than this is treated as zero length (cannot be normalised
#: without amplifying round-off to O(1) direction errors).
NORMAL_ZERO_LENGTH = 1e-12

#: Angles between normals below this are treated as exactly 0 (thesis Def. 15):
#: arccos of a dot product of identical unit vectors can return ~1e-8 instead of 0.
ANGLE_ZERO = 1e-7

#: Relative tolerance for comparing squared distances when breaking ties in
#: k-nearest-neighbour queries: distances equal to within round-off are ties
#: and the smaller index wins (docs/decisions/neighbors.md).
DISTANCE_TIE_RTOL = 0.0

#: How many offending indices an error message lists before "...".
MAX_LISTED_INDICES = 5

#: normals room: a neighbourhood whose covariance has lambda_2 <= this * lambda_1
#: (coincident or collinear points) has no defined tangent plane; exactly collinear
#: samples give lambda_2 / lambda_1 ~ 1e-16 from round-off, a real thin strip of
#: points stays far above 1e-10.
NORMAL_DEGENERATE_RATIO = 1e-10

#: normals room: added to the MST edge weights 1 - |n_i . n_j| (scaled by
#: 1 + |p_i - p_j| / mean edge length) so parallel normals (weight exactly 0) are
#: not lost where a sparse graph reads weight 0 as "no edge" (scipy, and the
#: reference tests) and ties prefer shorter edges; far below the
#: angular term of any non-parallel pair (1 degree -> 1.5e-4).
MST_WEIGHT_EPS = 1e-9

#: normals room: the outward vote sum_i a_i n_i . (p_i - c) of a component counts
#: as undecided (open, planar-like patch) when below this fraction of
#: sum_i a_i |p_i - c|; the top-point rule decides instead.
OUTWARD_VOTE_RTOL = 1e-3

#: A mesh vertex whose summed face area vector is shorter than this fraction of
#: the summed lengths of those vectors has no defined normal (it is unreferenced,
#: lies only on zero-area faces, or its faces cancel); relative, so it does not
#: depend on the mesh's units. Round-off in the sums is ~1e-16 relative.
MESH_NORMAL_CANCEL_RTOL = 1e-12

#: VSA switch (segment): a point moves only when its energy term drops by more than
#: this (absolute, in units of weight x squared normal distance); keeps round-off
#: in dot products of near-identical proxies from moving points back and forth.
VSA_SWITCH_MIN_GAIN = 1e-12

#: VSA (segment): default bound on a region's mean normal deviation angle (radians,
#: arccos of the mean cosine |S|/W) when neither eta nor max_angle is given.
#: 10 degrees gives ~10 regions around a cylinder, independent of the sampling density.
VSA_DEFAULT_MAX_ANGLE = 0.17453292519943295

#: simplify: singular values of a vertex's stacked proxy-plane normals below this
#: fraction of the largest are treated as zero in the least-squares intersection.
#: For two planes the ratio is tan(theta/2); 0.0437 = tan(2.5 deg), i.e. planes
#: within 5 degrees of parallel do not fix the vertex along that direction (the
#: near-parallel Fandisk outliers of thesis Fig. 4.11).
SIMPLIFY_PLANE_SV_RTOL = 0.0437

#: simplify: a least-squares vertex may lie at most this fraction of the distance
#: from its witness points to the nearest contributing region centroid away from
#: the witness points; farther solutions drop the weakest plane direction.
SIMPLIFY_VERTEX_BOUND = 0.5

#: simplify: the Eq. 4.12 optimisation counts as successful when every constraint
#: holds to this tolerance in coordinates scaled by the RMS radius of the points
#: (1e-9 of the model size, far below any sampling spacing).
SIMPLIFY_CONSTRAINT_TOL = 1e-9

#: simplify: all proxy normals within this angle (radians, 5 deg) of one direction
#: (up to sign) means all proxy planes are parallel and no vertex is defined.
SIMPLIFY_PARALLEL_ANGLE = 0.08726646259971647

#: VSA (segment): safety cap on the iterations of the main loop in which merges
#: are allowed. Merges may raise the energy (thesis 4.3.3 b); they stop at the
#: first round in which split and merge do not reduce the number of regions (see
#: docs/decisions/segment.md), which on the benchmark scene happens after
#: 3-10 rounds; afterwards only split, switch and update run, which never raise
#: the energy, so the loop terminates (Theorem 1).
VSA_MERGE_ROUNDS = 50

#: VSA (segment), local mode (`VSAOptions.local`): merges accept a union only
#: within this fraction of the threshold (max angle x 0.7, or 0.7 eta), so regions
#: the switch then grows stay under the threshold without splits. Measured on the
#: 1M-point lidar scan (0.6 / 0.7 / 0.8 / 1.0; docs/decisions/segment.md "Local
#: mode"): 0.7 is the largest that keeps tiled vs untiled within 1 % on regions and
#: energy on both seeds and both tile sizes.
VSA_LOCAL_MERGE_FACTOR = 0.7

#: VSA (segment): when more than this share of the regions changed since the last
#: merge round, the merge scans every boundary point for candidate pairs instead of
#: first collecting the boundary points next to a changed region (same pairs, cheaper
#: bookkeeping). The switch has its own exact skip rule (batch_switch_bounded).
VSA_MERGE_FULL_SCAN_SHARE = 0.5

#: Safety margin of the k-NN grid (pointatlas.neighbors), relative to the cell
#: size: cell faces computed as lo + i * h and the floor() that assigns points to
#: cells can disagree by round-off, so pruning and "search finished" bounds are
#: shrunk by this much (far above float64 round-off for <= 2**21 cells per axis).
GRID_CELL_MARGIN = 1e-6

#: Relative margin certifying a cKDTree candidate list (pointatlas.neighbors): the
#: tree's squared distances may differ from ours by round-off, so a row is only
#: final when the first left-out candidate is farther by more than this.
KDTREE_CERTIFY_RTOL = 1e-12

#: Relative widening of the radius handed to cKDTree for closed-ball queries; the
#: exact test (squared distance <= radius**2) is re-applied afterwards.
RADIUS_QUERY_WIDEN = 1e-9

#: cover (cloud surfaces): balls are closed and a point counts as inside when
#: |y - c|^2 <= r^2 (1 + this). The balls of Props 4-5 meet exactly on their
#: boundaries (the cube centre lies at distance sqrt(3)/2 from four lattice points),
#: where round-off in r^2 (0.75 comes out as 0.7499999999999999) would otherwise
#: leave such a point in no ball; 1e-12 is far above that round-off and far below
#: any sampling spacing.
COVER_RADIUS_RTOL = 1e-12

#: cover: a rotation matrix is accepted when |R^T R - I| and |det R - 1| are below
#: this (and, for a 2-D cover, its z row and column differ from e_z by less): loose
#: enough for a rotation written to text with 10 digits, tight enough that a
#: scaling or shear is refused.
COVER_ROTATION_TOL = 1e-9

#: cover: at most this many lattice spacings along the points' bounding box; a
#: smaller grid scale is refused with a message (it would build ~1e18 lattice codes
#: and overflow the int64 codes of the membership kernel long before that).
COVER_MAX_CELLS_PER_AXIS = 1e6

#: complex (Def 7 iii): the exact Hamiltonian-path search over the faces at a vertex
#: (needed only where an edge at the vertex lies in three or more faces) runs for at
#: most this many faces; the search is exponential, and a larger star falls back to
#: "connected with every face adjacent to at most two others" (then a path exists).
FAN_EXACT_MAX = 10

#: dynamics (Algorithm 3): a triangle, edge or area-weighted normal shorter than this
#: fraction of the realisation's bounding-box diagonal (squared for areas) is
#: degenerate: its frame is undefined and its points are reported instead of moved.
#: Relative, so independent of units; round-off in cross products is ~1e-16.
DEFORM_DEGENERATE_RTOL = 1e-12

#: dynamics: the minimal rotation taking a vertex normal n to n~ is undefined when
#: n . n~ <= -1 + this (antipodal normals; the Rodrigues factor 1 / (1 + cos) would
#: blow up); such points are reported as "vertex normal reversed".
DEFORM_ANTIPODAL_TOL = 1e-12

#: synth (Algorithm 1): a triangle corner whose shorter edge is below this fraction
#: of the mesh's bounding-box diagonal has no usable local frame (the ball of
#: Eq. 2.1 would have radius ~0); such meshes are refused with the faces named.
MESH_CLOUDS_DEGENERATE_RTOL = 1e-12

#: denoise: default neighbourhood of the normal voting filter ([YRS+18] as
#: reconstructed, docs/decisions/denoise.md) is the ball of this radius in units of
#: l (mean 6-NN spacing): 2 l holds ~21 points of a square grid, ~16 mesh vertices.
DENOISE_RADIUS_FACTOR = 2.0

#: denoise: fewest points of a default neighbourhood (a 6-NN ring plus the point),
#: so sparse regions still get a tensor of rank >= 2 to vote with.
DENOISE_K_MIN = 7

#: denoise: most points of a default neighbourhood; bounds the cost on dense
#: clusters, and K_MAX + K_WIDTH (58) fits the 62-bit weight patterns the adaptive
#: search caches.
DENOISE_K_MAX = 48

#: denoise: half-width of the thesis' adaptive range, k in [k_i - 10, k_i + 10]
#: (thesis 5.4, application scenario).
DENOISE_K_WIDTH = 10

#: Largest iteration count an option takes (denoise's ``--n-iter`` and ``n_iter=``):
#: every iteration is at least one pass over all points (a k-NN query in flatness,
#: a filter round in normal voting), so 10^5 of them on 10^5 points already take
#: hours, and flatness sizes its schedule by the count (10^12 asked for terabytes
#: and was answered "out of memory"). A larger count is refused with this reason.
MAX_ITERATIONS = 100_000

#: simplify (self-intersections): two triangles cross when they pass through each
#: other by more than this fraction of the mesh's bounding-box diagonal (each reaching
#: past it to both sides of the other's plane, their common segment longer). Far
#: above the round-off of the plane distances (~1e-16 of the diagonal, coordinates
#: taken from the box's centre), far below any feature a mesh keeps.
CROSSING_RTOL = 1e-10

#: simplify (self-intersections): two triangles whose corners all lie within this
#: fraction of the diagonal of the other's plane are tested in one plane: a planar
#: face's triangles (flat within 1e-7 of the diagonal, `PLANAR_RTOL`), where a fold
#: shows only as an overlap in the plane.
CROSSING_FLAT_RTOL = 1e-7
