"""Type stubs of the compiled module gimm._gimm (python/src/*.cpp), for editors and type checkers.

Units and conventions: world = patient LPS millimetres (+x left, +y posterior, +z head); images
(rows, cols) with pixel (row i, col j) centred at (u, v) = (j, i); point arrays (N, 2) of
(u, v) = (column, row) pixels; volumes (nx, ny, nz) indexed [i, j, k] (Fortran order) with a
geometry dict; fundamental matrices x_b^T F x_a = 0; angles in degrees (+LAO/-RAO,
+cranial/-caudal). tests/python/test_stub.py checks that these names match the module.
"""
from os import PathLike
from typing import Any, Dict, List, Literal, Mapping, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, PathLike]
_Array = npt.ArrayLike
_F64 = npt.NDArray[np.float64]
_F32 = npt.NDArray[np.float32]
_U8 = npt.NDArray[np.uint8]
_I32 = npt.NDArray[np.int32]
_I64 = npt.NDArray[np.int64]
_Bool = npt.NDArray[np.bool_]
_Model = Literal["perspective", "orthographic"]
_Gate = Literal["hard", "soft", "logit", "none"]
_System = Literal["LCA", "RCA"]


class Geometry(TypedDict, total=False):
    """A volume's placement: world = origin + direction @ diag(spacing) @ (i, j, k)."""
    dims: Tuple[int, int, int]
    spacing: _F64  # (3,) mm per voxel along i, j, k
    origin: _F64  # (3,) world mm of the centre of voxel (0, 0, 0)
    direction: _F64  # (3, 3) columns: world directions of the i, j, k axes


class Centerlines(TypedDict):
    points: _F64  # (N, 3) world mm
    radius: _F64  # (N,) lumen radius, mm
    branch: _I32  # (N,) index into the branch lists
    index: _I32  # (N,) point index within its branch
    branch_names: List[str]
    branch_systems: List[str]
    branch_parents: _I32  # (B,) -1 for a root


class Error(RuntimeError):
    """Every error gimm raises (gimm::Error); the message starts with 'gimm: '."""


class IoError(Error, OSError):
    """A file could not be opened, read or written (gimm::IoError)."""


class FormatError(Error, ValueError):
    """A file's content is malformed (gimm::FormatError)."""


def set_num_threads(n: int) -> None: ...
def get_num_threads() -> int: ...


# ---- geometry -------------------------------------------------------------------------------

class Camera:
    """P = K [R | t]: world mm -> pixels. See help(gimm.Camera)."""

    def __init__(self, K: _Array, R: _Array, t: _Array, rows: int, cols: int,
                 model: _Model = "perspective") -> None: ...
    @property
    def model(self) -> _Model: ...
    @property
    def K(self) -> _F64: ...  # (3, 3)
    @property
    def R(self) -> _F64: ...  # (3, 3)
    @property
    def t(self) -> _F64: ...  # (3,) mm
    @property
    def P(self) -> _F64: ...  # (3, 4)
    @property
    def center(self) -> _F64: ...  # (3,) world mm
    @property
    def principal_axis(self) -> _F64: ...  # (3,) unit, source -> detector
    @property
    def rows(self) -> int: ...
    @property
    def cols(self) -> int: ...
    @property
    def shape(self) -> Tuple[int, int]: ...
    def project(self, points: _Array) -> Tuple[Any, Any]:
        """(N, 3) mm -> (uv (N, 2) px, depth (N,) mm); (3,) -> ((2,), float)."""
    def ray(self, u: float, v: float) -> Tuple[_F64, _F64]:
        """(origin (3,) mm, unit direction (3,)) of the ray through pixel (u, v)."""
    def on_detector(self, uv: _Array) -> _Bool: ...


class CArm:
    """A C-arm pose and detector (DICOM XA conventions). See help(gimm.CArm)."""

    primary_deg: float
    secondary_deg: float
    sid_mm: float
    sod_mm: float
    rows: int
    cols: int
    pixel_mm: float
    pixel_row_mm: float
    principal_point: Optional[_F64]
    isocenter: _F64
    table_mm: _F64
    reference_table_mm: _F64
    patient_position: Literal["HFS", "FFS"]
    model: _Model

    def __init__(self, *, primary_deg: float = 0.0, secondary_deg: float = 0.0,
                 sid_mm: float = 1000.0, sod_mm: float = 750.0, rows: int = 512, cols: int = 512,
                 pixel_mm: float = 0.5, pixel_row_mm: float = 0.0,
                 principal_point: Optional[_Array] = None, isocenter: Optional[_Array] = None,
                 table_mm: Optional[_Array] = None, reference_table_mm: Optional[_Array] = None,
                 patient_position: Literal["HFS", "FFS"] = "HFS",
                 model: _Model = "perspective") -> None: ...
    def camera(self) -> Camera: ...
    def validate(self) -> None: ...
    def rotation(self) -> _F64: ...
    def source_direction(self) -> _F64: ...
    def source_position(self) -> _F64: ...
    def table_shift(self) -> _F64: ...
    def view_isocenter(self) -> _F64: ...
    def row_pixel_mm(self) -> float: ...
    def principal_point_or_centre(self) -> _F64: ...


_CameraLike = Union[Camera, CArm]


def fundamental_from_cameras(camera_a: _CameraLike, camera_b: _CameraLike) -> _F64: ...
def fundamental_8pt(points_a: _Array, points_b: _Array,
                    weights: Optional[_Array] = None) -> Optional[_F64]: ...
def fundamental_affine(points_a: _Array, points_b: _Array,
                       weights: Optional[_Array] = None) -> Optional[_F64]: ...
def estimate_fundamental_ransac(points_a: _Array, points_b: _Array, *,
                                model: Literal["perspective", "affine"] = "perspective",
                                distance: Literal["sampson", "symmetric"] = "sampson",
                                threshold_px: float = 1.0, confidence: float = 0.999,
                                max_iterations: int = 10000, min_iterations: int = 10,
                                local_optimization_steps: int = 3,
                                seed: int = 0) -> Dict[str, Any]: ...
def symmetric_epipolar_distance_sq(F: _Array, points_a: _Array, points_b: _Array) -> _F64: ...
def sampson_distance_sq(F: _Array, points_a: _Array, points_b: _Array) -> _F64: ...
def epipolar_lines_b(F: _Array, points_a: _Array) -> _F64: ...
def gate_with_fundamental(F: _Array, points_a: _Array, points_b: _Array, confidence: _Array, *,
                          mode: _Gate = "hard", tau: float = 2.0,
                          delta_px: float = 2.0) -> Dict[str, Any]: ...
def fundamental_from_matches(points_a: _Array, points_b: _Array, confidence: _Array, *,
                             top_k: int = 256, min_matches: int = 32) -> Optional[_F64]: ...
def gate_reference(points_a: _Array, points_b: _Array, confidence: _Array, *,
                   mode: _Gate = "hard", tau: float = 2.0, delta_px: float = 2.0,
                   top_k: int = 256, min_matches: int = 32) -> Dict[str, Any]: ...
def triangulate(cameras: Sequence[_CameraLike], pixels: _Array,
                method: Literal["dlt", "midpoint"] = "dlt") -> Optional[_F64]: ...


# ---- volumes, files, the phantom, anatomy, the view protocol --------------------------------

def read_volume(path: _Path, dtype: Literal["float32", "int16", "uint8"] = "float32"
                ) -> Tuple[np.ndarray, Geometry]: ...
def read_nifti(path: _Path, dtype: Literal["float32", "int16", "uint8"] = "float32"
               ) -> Tuple[np.ndarray, Geometry]: ...
class Volume:
    """A volume and its geometry, read in place of the caller's array when its layout is gimm's
    (float32, or uint8/bool for a mask, Fortran order, writeable); else one converted copy."""

    def __init__(self, array: np.ndarray, geometry: Optional[Mapping[str, Any]] = None, *,
                 spacing: Optional[_Array] = None, origin: Optional[_Array] = None,
                 direction: Optional[_Array] = None,
                 dtype: Optional[Literal["float32", "int16", "uint8"]] = None) -> None: ...
    @property
    def is_view(self) -> bool: ...
    @property
    def dtype(self) -> str: ...
    @property
    def shape(self) -> Tuple[int, int, int]: ...
    @property
    def geometry(self) -> Dict[str, Any]: ...
    @property
    def array(self) -> np.ndarray: ...
    def __getitem__(self, ijk: Tuple[int, int, int]) -> float: ...
    def sample(self, world_mm: _Array) -> float: ...


_VolumeLike = Union[np.ndarray, Volume]


def write_nifti(path: _Path, volume: _VolumeLike, geometry: Optional[Mapping[str, Any]] = None,
                description: str = "gimm") -> None: ...
def read_png(path: _Path) -> _F32: ...
def read_camera(path: _Path) -> Camera: ...
def make_phantom(seed: int = 0, size: Literal["small", "imagecas", "chest"] = "small",
                 dominance: Literal["auto", "right", "left", "codominant"] = "auto",
                 noise_hu: float = 15.0,
                 tree: Literal["classic", "rich"] = "classic") -> Dict[str, Any]: ...
def split_coronary_systems(label: _VolumeLike, geometry: Optional[Mapping[str, Any]] = None, *,
                           min_voxels: int = 20, allow_single: bool = False) -> Dict[str, Any]: ...
def vessel_isocenter(mask: _VolumeLike, geometry: Optional[Mapping[str, Any]] = None) -> _F64: ...
def extract_centerlines(mask: _VolumeLike, geometry: Optional[Mapping[str, Any]] = None, *,
                        system: _System = "LCA", min_spur_mm: float = 3.0,
                        spur_radius_factor: float = 2.5) -> Centerlines: ...
def routine_views() -> List[Dict[str, Any]]: ...
def view_class_from_angles(primary_deg: float, secondary_deg: float,
                           system: Optional[_System] = None) -> Tuple[int, float]: ...
def sample_view(view_class: int, seed: int = 0, jitter_deg: float = 5.0) -> Tuple[float, float]: ...
def plan_views(system: _System, *, mode: Literal["shared", "per_pair"] = "shared", seed: int = 0,
               jitter_deg: float = 5.0) -> Dict[str, Any]: ...


# ---- rendering and labels -------------------------------------------------------------------

class Renderer:
    """Prepare a patient once, render any number of views. See help(gimm.Renderer)."""

    def __init__(self, volume: _VolumeLike, mask: Optional[_VolumeLike] = None, *,
                 geometry: Optional[Mapping[str, Any]] = None, spacing: Optional[_Array] = None,
                 origin: Optional[_Array] = None, direction: Optional[_Array] = None,
                 recipe: Union[Literal["angiography", "reference", "none"], Mapping[str, Any]]
                 = "angiography",
                 pad_mm: float = 80.0, projector: Literal["siddon", "trilinear"] = "siddon",
                 step_mm: float = 0.0, vessel_depth: bool = False, min_chord_mm: float = 1e-6,
                 vessels: Literal["voxel", "mesh"] = "voxel", smooth_voxel_steps: bool = False,
                 name: str = "volume") -> None: ...
    def render(self, camera: _CameraLike, intensity: bool = True) -> Dict[str, np.ndarray]:
        """line_integrals, intensity (float32), vessel_mask, overlap (uint8), depth_mm
        (float32): (rows, cols) views of gimm's buffers, no copy."""
    def unoccluded(self, camera: _CameraLike, points: _Array) -> _Bool: ...
    @property
    def has_vessels(self) -> bool: ...


def label_view(points: Union[Centerlines, Mapping[str, Any], _Array], camera: _CameraLike,
               vessel_mask: Optional[np.ndarray] = None, overlap: Optional[np.ndarray] = None,
               renderer: Optional[Renderer] = None) -> Dict[str, np.ndarray]: ...
def farthest_point_sampling(points: _Array, count: int, seed: int = 0) -> np.ndarray: ...
def label_pair(points: Union[Centerlines, Mapping[str, Any], _Array], camera_a: _CameraLike,
               camera_b: _CameraLike, mask_a: Optional[np.ndarray] = None,
               mask_b: Optional[np.ndarray] = None, *, sparse_count: int = 20,
               seed: int = 0) -> Dict[str, Any]: ...


# ---- matching and metrics -------------------------------------------------------------------

class Matcher:
    """The GIMM learned matcher on gimm's CPU engine. See help(gimm.Matcher)."""

    def __init__(self, weights: Optional[_Path] = None) -> None: ...
    @property
    def input_size(self) -> int: ...
    @property
    def input(self) -> str: ...
    def match(self, image_a: np.ndarray, image_b: np.ndarray, class_a: int = 0, class_b: int = 0,
              camera_a: Optional[_CameraLike] = None, camera_b: Optional[_CameraLike] = None, *,
              gate: Optional[_Gate] = None, tau: float = 2.0, delta_px: Optional[float] = None,
              top_k: int = 256, min_matches: int = 32, input_size: Optional[int] = None,
              snap_to_epipolar: Optional[bool] = None, field_a: Optional[np.ndarray] = None,
              field_b: Optional[np.ndarray] = None) -> Dict[str, Any]: ...


def network_image(image: np.ndarray, input: Literal["intensity", "vesselness"]) -> np.ndarray: ...


def match_geometric(image_a: np.ndarray, image_b: np.ndarray, camera_a: _CameraLike,
                    camera_b: _CameraLike, *, mask_a: Optional[np.ndarray] = None,
                    mask_b: Optional[np.ndarray] = None, tolerance_px: float = 3.0,
                    exact_vesselness: bool = False,
                    min_confidence: Optional[float] = None,
                    field_a: Optional[np.ndarray] = None, field_b: Optional[np.ndarray] = None,
                    detect_fields: Optional[bool] = None,
                    keep_catheter: bool = False) -> Dict[str, Any]: ...
def exposed_field(image: np.ndarray) -> np.ndarray: ...
def match_dataset(dataset: _Path, out: _Path,
                  matcher: Union[Matcher, Literal["geometric", "epipolar", "oracle"]], *,
                  split: Literal["all", "train", "val", "test"] = "all",
                  images: Literal["auto", "rendered", "formed"] = "auto",
                  use_cameras: bool = True, camera_error_deg: float = 0.0,
                  camera_error_mm: float = 0.0, noise_photons: float = 0.0, blur_px: float = 0.0,
                  seed: int = 0, **kwargs: Any) -> Dict[str, Any]: ...
def match_baseline(truth: Mapping[str, Any], method: Literal["epipolar", "oracle"] = "epipolar",
                   *, sigma_px: float = 1.0, max_points: int = 300,
                   seed: int = 0) -> Dict[str, Any]: ...
def evaluate(truth: Union[Mapping[str, Any], Sequence[Mapping[str, Any]]],
             predictions: Union[Mapping[str, Any], Sequence[Optional[Mapping[str, Any]]]],
             top_k: int = 20, radius_px: float = 3.0) -> Dict[str, Any]: ...
def evaluate_dataset(dataset: _Path, predictions: _Path, *,
                     split: Literal["all", "train", "val", "test"] = "all", top_k: int = 20,
                     method: str = "", worst: int = 10,
                     out: Optional[_Path] = None) -> Dict[str, Any]: ...
def read_user_truth(path: _Path, radius_px: float = 3.0) -> Dict[str, Any]: ...
def read_matches(path: _Path) -> Dict[str, Any]: ...
def write_matches(path: _Path, predictions: Mapping[str, Any],
                  pair: Optional[str] = None) -> None: ...


# ---- datasets -------------------------------------------------------------------------------

_Split = Literal["all", "train", "val", "test"]


class Dataset:
    """A gimm-dataset folder, read as gimm-match and gimm-eval read it. See help(gimm.Dataset)."""

    def __init__(self, path: _Path) -> None: ...
    def patients(self, split: _Split = "all") -> List[str]: ...
    def pair_ids(self, split: _Split = "all") -> List[str]: ...
    def pair(self, id: str) -> Dict[str, Any]:
        """The pair's truth: id, system, view_a, view_b, view_class_a, view_class_b, F (3, 3),
        points_a, points_b (N, 2) px, world_mm (N, 3), mask_a, mask_b (rows, cols) uint8."""
    def camera(self, patient: str, view: str) -> Camera: ...
    def image(self, patient: str, view: str) -> _F32: ...
    @property
    def manifest(self) -> Dict[str, Any]: ...
    @property
    def root(self) -> str: ...


# ---- X-ray angiography DICOM (in builds with GDCM) ------------------------------------------

def read_xa_dicom(path: _Path, *, frame: Optional[int] = None,
                  pitch_mm: Optional[float] = None) -> Dict[str, Any]:
    """image (rows, cols) float32, carm (CArm), frame, frames, table_source, tags, warnings,
    explain."""
def write_xa_dicom(path: _Path, image: np.ndarray, carm: CArm, *, ge_table: bool = False) -> None: ...
