"""Type stubs for the Rust extension module ``miniskeleton_core``.

Arrays: ``vertices``/``bone_heads``/``bone_tails`` are (n, 3) float32 in one common space (the
add-on uses the armature's frame: its origin and axes, at world size); ``triangles`` (m, 3)
uint32; results are dense top-k ``indices`` int32 (n, k) (-1 = unused slot) and ``weights``
float32 (n, k), rows summing to 1, with k = min(max_influences, number of bones). Index arrays
(triangles, parents, mirrors, ``lbs`` indices) may be any numeric dtype but must hold whole
numbers in range, or ValueError.
"""

from typing import Callable, Iterator, List, Optional, Sequence, Tuple, TypedDict, Union, Unpack, final

import numpy as np
import numpy.typing as npt

__version__: str

class Cancelled(Exception):
    """A progress callback returned False."""

def _raise_test_panic() -> None:
    """Panic inside the core's boundary on purpose; raises RuntimeError on every platform."""

ArrayLike = npt.ArrayLike

@final
class Influences:
    """Top-k weights: indices (n,k) int32 (-1 unused), weights (n,k) float32. They unpack and
    index in that order: ``indices, weights = heat_weights(...)``."""
    @property
    def indices(self) -> npt.NDArray[np.int32]: ...
    @property
    def weights(self) -> npt.NDArray[np.float32]: ...
    def __iter__(self) -> Iterator[npt.NDArray[np.generic]]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, key: int, /) -> npt.NDArray[np.generic]: ...

def idw_weights(
    vertices: ArrayLike, bone_heads: ArrayLike, bone_tails: ArrayLike, *,
    max_influences: int = 4, power: float = 2.0, epsilon: float = 1e-4,
) -> Influences:
    """Inverse-distance weights w_b = (d_b+eps)^-p / sum_k (d_k+eps)^-p to bone segments (eps relative to mesh size)."""

class BilinearOptions(TypedDict, total=False):
    """The keywords of bilinear_weights; each one left out takes the core's default
    (max_influences 4, nearest 3, falloff "gaussian" with sigma None: half the median bone
    length; "inverse_power" with power 2)."""
    max_influences: int
    nearest: int
    falloff: str
    sigma: Optional[float]
    power: float

def bilinear_weights(
    vertices: ArrayLike, bone_heads: ArrayLike, bone_tails: ArrayLike,
    parents: Optional[ArrayLike] = None, **options: Unpack[BilinearOptions],
) -> Influences:
    """K = nearest (>= 1) nearest bones with radial falloff, each share split with the neighbour across the
    nearer joint. nearest or max_influences of 0 is a ValueError; an unknown keyword a TypeError."""

class HeatOptions(TypedDict, total=False):
    """The keywords of the heat functions (heat_weights, heat_weights_report, heat_weights_many,
    heat_sources, heat_weights_from_sources); each one left out takes its default.

    max_influences (4): bones kept per vertex (>= 1), the weakest fading out as a bone leaves
    them (with t the strongest left out, a kept w < 2 t becomes 2 (w - t)). min_weight (1e-3):
    weights below it, relative to the vertex's total, are dropped. visibility (True): ray test (a vertex takes
    the nearest bone it sees through the mesh); False: the nearest bone. weld_tolerance (1e-5)
    and every other length are relative to the bounding box of the vertices that faces use (a
    stray loose vertex does not change them). heat_constant (1.0): c in H = 4 c / d^2.
    bone_mirror (None), (b,): mirror bone of each bone (itself for centre bones, -1 for a side
    bone with no partner); with it, mirrored vertices get mirrored weights across the plane
    x[symmetry_axis] = 0 (symmetry_axis 0, 1 or 2, default 0), vertices matched within
    symmetry_tolerance (1e-3). A bone given as its own mirror with an end more than 1 % of the
    skeleton's size off the plane is a side bone whose name carries no side: paired with the
    bone at its mirror image, or left unaveraged (report: side_bones_paired,
    side_bones_unpaired).
    parents (None), (b,): parent bone of each bone (-1 for roots), for imported (glTF/FBX) rigs
    whose tails the importer invented: a bone whose children start away from its tail is then
    the segments from its head to their heads that lie inside the mesh (plus head -> tail when a
    child starts there; head -> tail alone when no such segment is inside, e.g. a root on the
    ground); a bone with no children also continues its parent's line into the mesh, as long
    as itself.
    curve_points (None), (p,3) with curve_bones (None), (p,): interior points of bent bones
    (Blender's B-Bones in their rest curve), each bone's in order from head to tail; such a bone
    is the polyline head -> points -> tail, as Blender's bone heat splits a B-Bone into its
    segments.
    A keyword that is not one of these is a TypeError."""
    max_influences: int
    min_weight: float
    visibility: bool
    weld_tolerance: float
    heat_constant: float
    bone_mirror: Optional[ArrayLike]
    symmetry_axis: int
    symmetry_tolerance: float
    parents: Optional[ArrayLike]
    curve_points: Optional[ArrayLike]
    curve_bones: Optional[ArrayLike]

def heat_weights(
    vertices: ArrayLike, triangles: ArrayLike, bone_heads: ArrayLike, bone_tails: ArrayLike, *,
    progress: Optional[Callable[[float], Optional[bool]]] = None, **options: Unpack[HeatOptions],
) -> Influences:
    """Bone-heat weights (Baran & Popovic 2007) on the position-welded surface; never leaves a vertex unweighted.
    options: see HeatOptions. progress(fraction) is called while solving: returning False cancels
    (Cancelled); an exception it raises stops the solve and propagates as itself."""

@final
class WeightsReport:
    """What a heat or voxel bind did: pieces, fallback_pieces (saw no bone), rigid_pieces,
    boneless_pieces, spanning_pieces (bone-less pieces that no one bone owns, solved by heat),
    isolated_vertices, welded_vertices, flipped_faces (wound against their neighbours; turned for
    the normals only), mirrored_vertices (with bone_mirror: vertices with a mirror twin or on the
    plane, the only ones averaged), side_bones_paired / side_bones_unpaired, regularized,
    factorization_failed, timings (stage -> seconds); voxel_weights only (None for heat): grid
    (3 ints), solid_voxels, outside_bones."""
    @property
    def pieces(self) -> int: ...
    @property
    def fallback_pieces(self) -> int: ...
    @property
    def rigid_pieces(self) -> int: ...
    @property
    def boneless_pieces(self) -> int: ...
    @property
    def spanning_pieces(self) -> int: ...
    @property
    def isolated_vertices(self) -> int: ...
    @property
    def welded_vertices(self) -> int: ...
    @property
    def flipped_faces(self) -> int: ...
    @property
    def mirrored_vertices(self) -> int: ...
    @property
    def side_bones_paired(self) -> int: ...
    @property
    def side_bones_unpaired(self) -> int: ...
    @property
    def regularized(self) -> bool: ...
    @property
    def factorization_failed(self) -> bool: ...
    @property
    def timings(self) -> dict[str, float]: ...
    @property
    def grid(self) -> Optional[Tuple[int, int, int]]: ...
    @property
    def solid_voxels(self) -> Optional[int]: ...
    @property
    def outside_bones(self) -> Optional[int]: ...

@final
class Weights:
    """Top-k weights with their report: indices (n,k) int32 (-1 unused), weights (n,k)
    float32, report (WeightsReport)."""
    @property
    def indices(self) -> npt.NDArray[np.int32]: ...
    @property
    def weights(self) -> npt.NDArray[np.float32]: ...
    @property
    def report(self) -> WeightsReport: ...

def heat_weights_report(
    vertices: ArrayLike, triangles: ArrayLike, bone_heads: ArrayLike, bone_tails: ArrayLike, *,
    progress: Optional[Callable[[float], Optional[bool]]] = None, **options: Unpack[HeatOptions],
) -> Weights:
    """As heat_weights, with its report (WeightsReport)."""

def heat_peak_bytes(vertices: int, bones: int) -> int:
    """Estimated peak memory in bytes of one heat solve of that many vertices and bones (the Laplacian,
    its Cholesky factor, one block of the bones' right-hand sides), fitted on meshes up to 1M vertices;
    callers refuse a solve that would not fit before it starts."""

def heat_weights_many(
    meshes: Sequence[Tuple[ArrayLike, ArrayLike]], bone_heads: ArrayLike, bone_tails: ArrayLike,
    **options: Unpack[HeatOptions],
) -> List[Union[Weights, Exception]]:
    """heat_weights_report of several independent meshes [(vertices, triangles)] with the same bones
    and options, solved in parallel in one call (many small meshes: a call each costs more than its
    solve). One entry per mesh, in order: its Weights, or the exception it
    raised (ValueError for bad input, RuntimeError for an internal error in its solve, caught per
    mesh), returned so that the others' results stand."""

@final
class WeldedPoints:
    """weld_points' result: map (n,) int32, each point's welded point; welded (k,3) float64.
    They unpack in that order."""
    @property
    def map(self) -> npt.NDArray[np.int32]: ...
    @property
    def welded(self) -> npt.NDArray[np.float64]: ...
    def __iter__(self) -> Iterator[npt.NDArray[np.generic]]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, key: int, /) -> npt.NDArray[np.generic]: ...

def weld_points(points: ArrayLike, tolerance: float) -> WeldedPoints:
    """Weld points (n,3) (float64 or float32) closer than tolerance, an absolute distance in the
    points' own units: map (n,) int32, each point's welded point; welded (k,3) float64. Greedy
    in input order: a point joins a welded point within tolerance of it, else it becomes a new
    one; a welded point is the first point of its cluster, unchanged (not a mean), and clusters
    do not chain (a point near another member but farther than tolerance from the first starts a
    new one). Welded points lie more than tolerance apart; a point within tolerance of two of
    them joins one fixed by the grid, not always the first. tolerance <= 0 or not finite: exact
    duplicates only. Non-finite points never weld. (The weld heat_weights and touching_meshes
    use, there with a tolerance relative to the mesh's size.)"""

def heat_sources(
    vertices: ArrayLike, triangles: ArrayLike, bone_heads: ArrayLike, bone_tails: ArrayLike,
    **options: Unpack[HeatOptions],
) -> Influences:
    """Debug and evaluation: the heat sources heat_weights finds, as Influences (indices and weights (n,4)):
    per vertex its nearest visible bone (near-ties share equally; in a piece that sees no bone,
    its nearest bone by distance), an empty row where the vertex holds no heat."""

def heat_weights_from_sources(
    vertices: ArrayLike, triangles: ArrayLike, bone_heads: ArrayLike, bone_tails: ArrayLike,
    source_indices: ArrayLike, source_weights: ArrayLike, **options: Unpack[HeatOptions],
) -> Weights:
    """Debug and evaluation: heat_weights_report with the heat sources given instead of found, to
    measure the method apart from its choice of sources. source_indices (n,k) bones (-1 unused)
    and source_weights (n,k) their shares of each vertex's heat (fractions of the row's sum; the
    rows of vertices welded together add up; an empty row holds no heat): e.g. one bone per
    vertex as (bone[:, None], ones((n, 1))), or dense shares (n,b) as
    (tile(arange(b), (n, 1)), shares). The heat H = 4 c / d^2 keeps each vertex's distance d to
    its own source (as heat_sources finds it); rigid pieces and symmetry are as in heat_weights.
    With the sources of heat_sources, the weights of heat_weights_report, bit for bit."""

class VoxelOptions(TypedDict, total=False):
    """The keywords of voxel_weights; each one left out takes the core's default (resolution 64,
    falloff 0.002, max_influences 4, objects None: one object). bone_mirror, symmetry_axis,
    parents, curve_points, curve_bones: as in HeatOptions."""
    resolution: int
    falloff: float
    max_influences: int
    bone_mirror: Optional[ArrayLike]
    symmetry_axis: int
    parents: Optional[ArrayLike]
    curve_points: Optional[ArrayLike]
    curve_bones: Optional[ArrayLike]
    objects: Optional[ArrayLike]

def voxel_weights(
    vertices: ArrayLike, triangles: ArrayLike, bone_heads: ArrayLike, bone_tails: ArrayLike, *,
    progress: Optional[Callable[[float], Optional[bool]]] = None, **options: Unpack[VoxelOptions],
) -> Weights:
    """Geodesic voxel binding (Dionne & de Lasa 2013) of a whole character (every mesh stacked;
    objects (n,) the object of each vertex: one that holds no bone is a prop, bound rigidly).
    resolution: voxels along the longest side (16-1024); falloff (0-1): how far a vertex shares
    its heat with bones farther than its nearest, relative to the distance. Other keywords as
    heat_weights. Returns its Weights: the report has grid, solid_voxels, outside_bones and the
    voxel stages in timings."""

class VoxelDistanceOptions(TypedDict, total=False):
    """The keywords of voxel_distances: resolution, parents, curve_points, curve_bones and
    bone_mirror / symmetry_axis, as for voxel_weights."""
    resolution: int
    bone_mirror: Optional[ArrayLike]
    symmetry_axis: int
    parents: Optional[ArrayLike]
    curve_points: Optional[ArrayLike]
    curve_bones: Optional[ArrayLike]

@final
class VoxelDistances:
    """Each vertex's k nearest bones through the voxel solid: indices (n,k) int32 (-1
    unused); geodesic and straight distances (n,k) float32 in bbox diagonals; cosines (n,k)
    float32 between the vertex normal and the direction from the bone."""
    @property
    def indices(self) -> npt.NDArray[np.int32]: ...
    @property
    def geodesic(self) -> npt.NDArray[np.float32]: ...
    @property
    def straight(self) -> npt.NDArray[np.float32]: ...
    @property
    def cosines(self) -> npt.NDArray[np.float32]: ...

def voxel_distances(
    vertices: ArrayLike, triangles: ArrayLike, bone_heads: ArrayLike, bone_tails: ArrayLike, *,
    k: int = 8, **options: Unpack[VoxelDistanceOptions],
) -> VoxelDistances:
    """Debug and evaluation: each vertex's k nearest bones by geodesic distance through the voxel
    solid: (indices (n,k) int32, -1 unused; geodesic and straight distances (n,k) float32 in bbox
    diagonals; cosines (n,k) between the vertex normal and the direction from the bone)."""

class TransferOptions(TypedDict, total=False):
    """The keywords of transfer_weights; each one left out takes the core's default
    (max_distance 0.05, max_angle 30.0 degrees, flipped True, max_influences 4)."""
    max_distance: float
    max_angle: float
    flipped: bool
    max_influences: int

@final
class TransferReport:
    """What a transfer did: matched (garment vertices that took the body's weights
    where they lie on it), inpainted, nearest (vertices of pieces with no match, given their
    nearest points' weights), regularized."""
    @property
    def matched(self) -> int: ...
    @property
    def inpainted(self) -> int: ...
    @property
    def nearest(self) -> int: ...
    @property
    def regularized(self) -> bool: ...

@final
class TransferredWeights:
    """Transferred top-k weights: indices (n,k) int32, weights (n,k) float32, report
    (TransferReport)."""
    @property
    def indices(self) -> npt.NDArray[np.int32]: ...
    @property
    def weights(self) -> npt.NDArray[np.float32]: ...
    @property
    def report(self) -> TransferReport: ...

def transfer_weights(
    body_vertices: ArrayLike, body_triangles: ArrayLike, body_indices: ArrayLike, body_weights: ArrayLike,
    vertices: ArrayLike, triangles: ArrayLike, **options: Unpack[TransferOptions],
) -> TransferredWeights:
    """Robust skin weights transfer (Abdrashitov et al. 2023): a body's top-k weights (body_indices,
    body_weights (nb,k)) onto a garment in the same space. A garment vertex within max_distance
    (fraction of the body's bbox diagonal) of the body, its normal within max_angle degrees of the
    body's (or of its opposite, flipped), takes the body's weights there; the others are
    inpainted by a Laplacian solve; a piece with no such vertex takes its nearest points'
    weights. Returns TransferredWeights."""

def touching_meshes(vertices: ArrayLike, mesh_of: ArrayLike, meshes: int, *,
                    triangles: Optional[ArrayLike] = None, tolerance: float = 1e-5,
                    min_shared: int = 3) -> npt.NDArray[np.int32]:
    """(meshes,) group of each mesh: meshes sharing at least min_shared vertex positions (welded within
    tolerance of the bbox diagonal, as heat welds), transitively, are one group (a head and a body
    split at the neck), numbered in order of each group's first mesh. vertices (n,3) of all meshes
    stacked, mesh_of (n,) the mesh of each vertex, triangles (m,3) of all meshes stacked: the bbox of
    the vertices they use sets the scale (a stray loose vertex does not); without them, all vertices."""

def catmull_clark_limit(vertices: ArrayLike, face_sizes: ArrayLike, face_vertices: ArrayLike, *,
                        keep_corners: bool = False) -> npt.NDArray[np.float32]:
    """Catmull-Clark limit positions (n,3) of a polygon mesh's vertices: where a cage's vertices lie on
    the smooth surface of its Subdivision Surface modifier (as Blender's OpenSubdiv puts them; creases
    not read). face_sizes (f,) corners per face, face_vertices their vertex indices face after face.
    keep_corners: a boundary vertex of one face stays put (Blender's "Keep Corners"); loose and
    non-manifold vertices stay where they are."""

@final
class TriangleMesh:
    """A generated mesh: vertices (n,3) float32, triangles (m,3) uint32. They unpack in that
    order."""
    @property
    def vertices(self) -> npt.NDArray[np.float32]: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...
    def __iter__(self) -> Iterator[npt.NDArray[np.generic]]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, key: int, /) -> npt.NDArray[np.generic]: ...

@final
class BoneChain:
    """A generated bone chain: heads (b,3) float32, tails (b,3) float32, parents (b,) int32.
    They unpack in that order."""
    @property
    def heads(self) -> npt.NDArray[np.float32]: ...
    @property
    def tails(self) -> npt.NDArray[np.float32]: ...
    @property
    def parents(self) -> npt.NDArray[np.int32]: ...
    def __iter__(self) -> Iterator[npt.NDArray[np.generic]]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, key: int, /) -> npt.NDArray[np.generic]: ...

def capped_cylinder(radius: float = 0.5, height: float = 4.0, rings: int = 32, segments: int = 32
                    ) -> TriangleMesh:
    """Closed capped cylinder along +Z from z=0 to z=height."""

def bone_chain(height: float = 4.0, bones: int = 4) -> BoneChain:
    """Straight chain of equal bones along +Z inside a cylinder of that height."""

def split_flat(vertices: ArrayLike, triangles: ArrayLike) -> TriangleMesh:
    """Flat-shaded copy: three vertices per triangle. ValueError for a triangle with an index past
    the vertices (or negative), naming the triangle."""

def lbs(vertices: ArrayLike, indices: ArrayLike, weights: ArrayLike, bone_matrices: ArrayLike
        ) -> npt.NDArray[np.float32]:
    """Linear blend skinning v' = sum_j w_j M_j v. bone_matrices (b,4,4) row-major, rest->posed; rows
    whose weights do not sum to 1 are renormalized, all-zero rows stay at rest."""

@final
class Chain2d:
    """A planar chain (one puppet limb): lengths (b,), relative joint angles (b,) radians (default
    0), base (x, y), base_angle radians, limits (b, 2) radians (default none)."""
    def __new__(cls, lengths: ArrayLike, angles: Optional[ArrayLike] = None, *,
                base: Tuple[float, float] = (0.0, 0.0), base_angle: float = 0.0,
                limits: Optional[ArrayLike] = None) -> "Chain2d": ...
    @property
    def lengths(self) -> npt.NDArray[np.float64]: ...
    @property
    def angles(self) -> npt.NDArray[np.float64]: ...
    @property
    def base(self) -> Tuple[float, float]: ...
    @property
    def base_angle(self) -> float: ...
    @property
    def limits(self) -> npt.NDArray[np.float64]: ...

@final
class Ik2dOptions:
    """How to solve: at most max_iterations passes (at most 10000, ValueError above it: the solve
    runs without the GIL and cannot be interrupted), tolerance (default 1e-3 of the chain's
    reach), method 'ccd' (improved CCD with collinear/unreachable handling), 'ccd_pure',
    'ccd_classic3d', 'fabrik'."""
    def __new__(cls, *, max_iterations: int = 200, tolerance: Optional[float] = None,
                method: str = "ccd") -> "Ik2dOptions": ...
    @property
    def max_iterations(self) -> int: ...
    @property
    def tolerance(self) -> Optional[float]: ...
    @property
    def method(self) -> str: ...

@final
class Ik2dSolution:
    """What a solve found: relative angles (b,) radians, passes run, the final distance to the
    target (the largest over the effectors for ik2d_solve_multi), and whether it is within the
    tolerance."""
    @property
    def angles(self) -> npt.NDArray[np.float64]: ...
    @property
    def iterations(self) -> int: ...
    @property
    def error(self) -> float: ...
    @property
    def reached(self) -> bool: ...

def ik2d_solve(chain: Chain2d, target: Tuple[float, float], options: Optional[Ik2dOptions] = None
               ) -> Ik2dSolution:
    """Planar IK on one chain, from its angles toward target (x, y)."""

def ik2d_solve_multi(chain: Chain2d, effectors: list, options: Optional[Ik2dOptions] = None
                     ) -> Ik2dSolution:
    """Several effectors [(joint 1..b, (x, y), weight)] on one chain (strip puppets), by the
    improved CCD (options.method must be 'ccd')."""

def ik2d_forward(chain: Chain2d) -> npt.NDArray[np.float64]:
    """Joint positions (b+1, 2): the base, then each bone's tip."""

class FitOptions(TypedDict, total=False):
    """The keywords of fit_joints; each one left out takes the core's default (FitOptions:
    symmetry_axis None, symmetry_plane 0.0, joint_mirror None, rays 12, samples 5, rounds 12,
    tolerance 1e-4, stiffness 0.05, tip True, max_move 0.12, stub_ratio 0.5, min_sections 2)."""
    symmetry_axis: Optional[int]
    symmetry_plane: float
    joint_mirror: Optional[ArrayLike]
    rays: int
    samples: int
    rounds: int
    tolerance: float
    stiffness: float
    tip: bool
    max_move: float
    stub_ratio: float
    min_sections: int

@final
class FitResult:
    """The fitted joints (j,3) float32 and what the fit did: outside_before /
    outside_after (joints outside the mesh) with their (j,) bool masks, kept_outside, rounds,
    max_move, open_edges, nonmanifold_edges, pieces, mirrored_surface (with symmetry: share of the
    vertices whose mirror image lies within 1 % of the diagonal of the surface, else None),
    off_plane_centre."""
    @property
    def joints(self) -> npt.NDArray[np.float32]: ...
    @property
    def outside_before(self) -> int: ...
    @property
    def outside_after(self) -> int: ...
    @property
    def outside_before_mask(self) -> npt.NDArray[np.bool_]: ...
    @property
    def outside_after_mask(self) -> npt.NDArray[np.bool_]: ...
    @property
    def kept_outside(self) -> int: ...
    @property
    def rounds(self) -> int: ...
    @property
    def max_move(self) -> float: ...
    @property
    def open_edges(self) -> int: ...
    @property
    def nonmanifold_edges(self) -> int: ...
    @property
    def pieces(self) -> int: ...
    @property
    def mirrored_surface(self) -> Optional[float]: ...
    @property
    def off_plane_centre(self) -> int: ...

def fit_joints(vertices: ArrayLike, triangles: ArrayLike, joints: ArrayLike, bones: ArrayLike,
               movable: Optional[ArrayLike] = None, **options: Unpack[FitOptions]) -> FitResult:
    """Fit joints (j,3) into the mesh (same space): each goes to the nearest point of its bones'
    centre lines (cross-section centres); joints left outside are pulled in. bones (b,2) joint
    indices; movable (j,) bool; with symmetry_axis, joint_mirror (j,) pairs end exactly mirrored,
    centre joints (mirror = itself) on the plane, joints with mirror -1 are free, and so are centre
    joints farther than max_move from the plane (a side joint whose name has no side; counted in
    the report's off_plane_centre); joints that start farther than max_move outside keep their
    place (counted in kept_outside), and joints keep their place where their lines are not trusted
    (the core's do-no-harm FitOptions, at their defaults) (ValueError when
    the joints would move more than 10 % of the diagonal on average to meet their mirror images:
    not the rig's mirror plane). max_move caps a
    joint's fitting move (fraction of the bbox diagonal). A bone leaving a junction (a joint of 3+ bones)
    whose thinnest section's radius exceeds stub_ratio times its length (pelvis to hip) gives no
    centre line; 0 disables. A bone with fewer than min_sections usable sections (one pins a point,
    not a direction) gives no centre line either, nor does one whose sections' line runs more than
    60 degrees from the bone (slices of unrelated parts). Report: outside_before/after (+ _mask), kept_outside,
    rounds, max_move,
    open_edges, nonmanifold_edges, pieces, mirrored_surface (with symmetry: share of the vertices whose
    mirror image lies within 1 % of the diagonal of the surface, else None), off_plane_centre."""

def points_inside(vertices: ArrayLike, triangles: ArrayLike, points: ArrayLike) -> npt.NDArray[np.bool_]:
    """(p,) bool: points inside the closed mesh by ray parity (majority of 7 directions)."""

def mirror_name(name: str) -> str:
    """Blender's left/right flip of a bone name: 'thigh.L' -> 'thigh.R', 'R_foot' -> 'L_foot',
    'leg_back_L_knee' -> 'leg_back_R_knee', 'mixamorig:LeftArm' -> 'mixamorig:RightArm'; the name
    itself when it states no side. The first token of these, in this order: a separator (. _ -
    space) and L/l at the end, then R/r; L/l and a separator at the start, then R/r; a letter
    between two of . _ -; the first Left, Right, left, right, LEFT or RIGHT. detect_roles reads
    a name's side by the same rule (the side of the token flipped)."""

def bone_mirror_indices(names: list[str]) -> npt.NDArray[np.int32]:
    """(b,) mirror bone of each bone by name: the bone named mirror_name(name) (the last such with
    duplicate names), or else the one bone whose name matches it up to a trailing number
    (b_LeftUpperArm_09 <-> b_RightUpperArm_06); itself for a centre bone (a name the flip leaves
    as it is); -1 for a side bone without a partner. Pairs agree both ways: the form of
    heat_weights' bone_mirror."""

# ---------------------------------------------------------------------------- autorig

@final
class AutoRig:
    """Auto Rig's skeleton: template ('BIPED'|'QUADRUPED'|'CHAIN'|'WINGED'), reason (why that
    template), names (basic_human / basic_quadruped / shark / bird names; ears as the horse's
    ear.L / ear.L.001), heads, tails (k,3)
    float32 (input units), parents (k,) int64 (-1 root; parents first), connected (k,) bool,
    forward, left (3,) float32 (left = the .L side), tail (tail bones were built),
    centre_points (c,3) float32, centre_edges (e,2) uint32 (the centre-line tree the bones
    follow)."""
    @property
    def template(self) -> str: ...
    @property
    def reason(self) -> str: ...
    @property
    def names(self) -> list[str]: ...
    @property
    def heads(self) -> npt.NDArray[np.float32]: ...
    @property
    def tails(self) -> npt.NDArray[np.float32]: ...
    @property
    def parents(self) -> npt.NDArray[np.int64]: ...
    @property
    def connected(self) -> npt.NDArray[np.bool_]: ...
    @property
    def forward(self) -> npt.NDArray[np.float32]: ...
    @property
    def left(self) -> npt.NDArray[np.float32]: ...
    @property
    def tail(self) -> bool: ...
    @property
    def centre_points(self) -> npt.NDArray[np.float32]: ...
    @property
    def centre_edges(self) -> npt.NDArray[np.uint32]: ...

def auto_rig(vertices: ArrayLike, triangles: ArrayLike, *, template: str = "AUTO",
             forward: Optional[ArrayLike] = None, resolution: int = 96) -> AutoRig:
    """A Rigify-metarig skeleton for a bare mesh of a character (+Z up, any pieces, any scale,
    facing any horizontal direction). template "AUTO" (legs that hold the body up: 2 biped, 4
    quadruped; wings spread: winged; no legs: chain) | "BIPED" | "QUADRUPED" | "CHAIN" |
    "WINGED"; forward (3,) overrides the facing found; resolution 16..512 voxels along the
    longest side. ValueError, saying why, for an empty or non-finite mesh and for a shape the
    templates do not fit: no enclosed volume, a round blob, too few feet for the template asked,
    no wings for WINGED, no head."""

# ---------------------------------------------------------------------------- motion

@final
class Limb:
    """A leg or an arm: bones (from the body outwards), side 'L' | 'R', group (legs: 0 the
    front pair, counting backwards; arms 0). Limbs with equal fields are equal."""
    @property
    def bones(self) -> list[int]: ...
    @property
    def side(self) -> str: ...
    @property
    def group(self) -> int: ...

@final
class Roles:
    """Bone roles found from the geometry (+Z up), names as hints: root, spine, neck, head,
    head_extras, tail, legs, arms (Limbs), plan ('biped'|'quadruped'|'multiped'|'legless': no
    legs found, legs empty), up, forward, left, ground, height, leg_length, single_tree (moving
    the root bone moves every role bone), riders ([(foot, leg bone)]: feet hanging off the root,
    as IK rigs exported to glTF have them, ride on their leg), notes."""
    @property
    def root(self) -> int: ...
    @property
    def spine(self) -> list[int]: ...
    @property
    def neck(self) -> list[int]: ...
    @property
    def head(self) -> int: ...
    @property
    def head_extras(self) -> list[int]: ...
    @property
    def tail(self) -> list[int]: ...
    @property
    def legs(self) -> tuple[Limb, ...]: ...
    @property
    def arms(self) -> tuple[Limb, ...]: ...
    @property
    def plan(self) -> str: ...
    @property
    def up(self) -> list[float]: ...
    @property
    def forward(self) -> list[float]: ...
    @property
    def left(self) -> list[float]: ...
    @property
    def ground(self) -> float: ...
    @property
    def height(self) -> float: ...
    @property
    def leg_length(self) -> float: ...
    @property
    def single_tree(self) -> bool: ...
    @property
    def riders(self) -> list[tuple[int, int]]: ...
    @property
    def notes(self) -> list[str]: ...

@final
class MotionClip:
    """A motion: rotations (frames,b,4) float32 local quaternions w,x,y,z; root_offset
    (frames,3) float32; animated (k,) int32; locations (frames,b,3) float32 local locations in
    the heads' units (zero but for located); located (j,) int32 (the riders); moves_root; frames;
    frames_per_cycle; roles."""
    @property
    def rotations(self) -> npt.NDArray[np.float32]: ...
    @property
    def root_offset(self) -> npt.NDArray[np.float32]: ...
    @property
    def animated(self) -> npt.NDArray[np.int32]: ...
    @property
    def locations(self) -> npt.NDArray[np.float32]: ...
    @property
    def located(self) -> npt.NDArray[np.int32]: ...
    @property
    def moves_root(self) -> bool: ...
    @property
    def frames(self) -> int: ...
    @property
    def frames_per_cycle(self) -> float: ...
    @property
    def roles(self) -> Roles: ...

def detect_roles(bone_heads: ArrayLike, bone_tails: ArrayLike, parents: ArrayLike,
                 names: Optional[list[str]] = None) -> Roles:
    """The roles of the bones (Roles). ValueError saying 'no head' when none can be found
    (make_motion's walk and run refuse a legless rig: 'no legs')."""

class MotionOptions(TypedDict, total=False):
    """The keywords of make_motion; each one left out takes the core's default (GaitParams: fps
    24, cycles 2, duration 2 s, amplitude 30 degrees in radians, stride 1, speed 1, root_motion
    True; joint_tails False, no skin, no path, level ground)."""
    fps: float
    cycles: float
    duration: float
    amplitude: float
    stride: float
    speed: float
    root_motion: bool
    joint_tails: bool
    skin_points: Optional[ArrayLike]
    skin_bones: Optional[ArrayLike]
    path: Optional[ArrayLike]
    ground: Optional[tuple[tuple[float, float], float, ArrayLike]]

def make_motion(
    bone_heads: ArrayLike, bone_tails: ArrayLike, parents: ArrayLike, rest_matrices: ArrayLike,
    motion: str = "WALK", *, names: Optional[list[str]] = None, **options: Unpack[MotionOptions],
) -> MotionClip:
    """'HEAD_SHAKE', 'WALK' or 'RUN' for a skeleton. rest_matrices (b,3,3): rest orientation per
    bone (columns = bone X, Y, Z) in the heads' space. joint_tails: the tails are an importer's
    invention, so roles and motion read tails made from the joints (children's heads).
    skin_points (p,3) and skin_bones (p,) int: the skin at rest in the heads' space and the bone
    weighing most on each point (-1: none): the feet stand on the ground its soles rest on (a
    body that does not stand level is settled first), arms hang clear of its body.
    path (p,3): a polyline the walk or run follows (cycles from its length; ValueError with
    root_motion off). ground ((x, y), cell, heights (ny,nx)): a height field, heights[j, i] at
    (x + i cell, y + j cell), NaN for a miss; the feet stand on it, turned to its slope.
    Returns a MotionClip."""
