"""Type stubs of the native module (Rust, PyO3)."""

from __future__ import annotations

from os import PathLike
from typing import Any, Dict, Iterable, Iterator, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
NUM_JOINTS: int
#: The 21 joints: wrist, then 4 per finger, thumb to little (MediaPipe's and OpenPose's order).
JOINT_NAMES: List[str]
#: OpenXR's 26 hand joints (``XrHandJointEXT`` order), the rows of ``Hand.xr_joints``.
XR_JOINT_NAMES: List[str]

class MonohandError(RuntimeError):
    """A model, file, video or fit failed (the message says which and why)."""

class Camera:
    """A camera (pixels; pixel centres at integer coordinates) with a lens model:
    ``"pinhole"``, optionally with OpenCV's distortion ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])``,
    or ``"fisheye"``, OpenCV's fisheye (Kannala-Brandt) with ``(k1, k2, k3, k4)``."""

    def __init__(
        self,
        fx: float,
        fy: float,
        cx: float,
        cy: float,
        width: int,
        height: int,
        distortion: Optional[Sequence[float]] = None,
        rotation: Optional[Sequence[Sequence[float]]] = None,
        translation_mm: Optional[Sequence[float]] = None,
        model: Literal["pinhole", "fisheye"] = "pinhole",
    ) -> None:
        """``x_cam = rotation @ x_ref + translation_mm`` for the later cameras of a rig.
        ``model="fisheye"`` takes 4 coefficients (or none); a fisheye past 180 degrees
        is refused."""
    @staticmethod
    def generic(width: int, height: int) -> Camera:
        """Principal point at the centre and a 60 degree horizontal field of view."""
    @staticmethod
    def load(path: Union[str, PathLike[str]]) -> Camera:
        """A calibration file: the project's JSON, WACV'18 JSON, OpenCV YAML or XML, ROS
        ``camera_info`` YAML, or one camera of a Kalibr camera chain (``"chain.yaml#cam1"``)."""
    @property
    def fx(self) -> float: ...
    @property
    def fy(self) -> float: ...
    @property
    def cx(self) -> float: ...
    @property
    def cy(self) -> float: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def model(self) -> Literal["pinhole", "fisheye"]:
        """The lens model."""
    @property
    def distortion(self) -> List[float]:
        """The coefficients as OpenCV lists them for the model (``[]`` for none)."""
    @property
    def rotation(self) -> npt.NDArray[np.float64]: ...
    @property
    def translation_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def k(self) -> npt.NDArray[np.float64]:
        """The 3x3 intrinsic matrix."""
    def project(self, points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """``(N, 3)`` mm to ``(N, 2)`` pixels; NaN behind the camera."""

class Pose:
    """The fitted model's 27 parameters."""

    @property
    def translation_mm(self) -> npt.NDArray[np.float64]:
        """``(3,)``: the wrist, mm, in the first camera's frame."""
    @property
    def quaternion_xyzw(self) -> npt.NDArray[np.float64]:
        """``(4,)``: the hand's rotation."""
    @property
    def angles_rad(self) -> npt.NDArray[np.float64]:
        """``(20,)``: joint angles, radians, thumb to little finger, 4 each."""

class Hand:
    """One hand of a frame: the fields of a ``hands`` entry of ``monohand run``'s JSON Lines."""

    @property
    def id(self) -> Optional[int]:
        """Identity over a session's frames (``None`` from ``lift``)."""
    @property
    def side(self) -> str:
        """``"left"`` or ``"right"``, voted over the hand's frames."""
    @property
    def side_score(self) -> Optional[float]: ...
    @property
    def score(self) -> Optional[float]:
        """Detection (presence) score."""
    @property
    def bbox(self) -> Optional[Tuple[float, float, float, float]]:
        """``(x0, y0, x1, y1)`` pixels around the keypoints."""
    @property
    def keypoints_2d(self) -> npt.NDArray[np.float64]:
        """``(21, 3)``: x, y (pixels of the first camera) and confidence."""
    @property
    def joints_3d_mm(self) -> Optional[npt.NDArray[np.float64]]:
        """``(21, 3)``: absolute 3D, mm, first camera's frame (x right, y down, z forward)."""
    @property
    def pose(self) -> Optional[Pose]: ...
    @property
    def reprojection_error_px(self) -> Optional[float]: ...
    @property
    def converged(self) -> Optional[bool]: ...
    @property
    def iterations(self) -> Optional[int]: ...
    @property
    def world_mm(self) -> Optional[npt.NDArray[np.float64]]:
        """``(21, 3)``: the landmark network's own wrist-relative 3D, mm."""
    @property
    def depth_px(self) -> Optional[npt.NDArray[np.float64]]:
        """``(21,)``: the landmark network's relative depth, pixels of its crop."""
    @property
    def xr_joints(self) -> Optional[npt.NDArray[np.float64]]:
        """``(26, 7)``: OpenXR's hand joints (``XR_JOINT_NAMES``): x, y, z (mm, the frame of
        ``joints_3d_mm``) and the orientation qx, qy, qz, qw (the joint's -Z along its bone
        towards the finger tip, +Y out of the back of the hand)."""
    @property
    def xr_radii(self) -> Optional[npt.NDArray[np.float64]]:
        """``(26,)``: each OpenXR joint's distance to the skin, mm."""
    @property
    def distance(self) -> Optional[Dict[str, float]]:
        """With one camera and a tracked hand: the palm's distance from the camera, mm:
        ``keypoints_mm`` and ``keypoints_sigma_mm`` (the keypoints alone, how firmly they pin
        it), ``cues_mm`` (the network's cues), ``fused_mm`` and ``fused_sigma_mm`` (the filter
        over the track); ``None`` otherwise."""
    def wrist_pose(self) -> Optional[npt.NDArray[np.float64]]:
        """``(4, 4)``: the wrist's pose, metres, first camera's frame: the transform from MANO's
        wrist frame (dex-retargeting's: +z towards the fingers, +x out of the palm, +y = z x x)
        to the camera's; ``None`` without 3D."""
    def joints_in_wrist_frame(self, convention: str = "mano") -> Optional[npt.NDArray[np.float64]]:
        """``(21, 3)``: the joints in the wrist frame of ``wrist_pose``, metres; ``convention``
        ``"mano"`` (another is a ``ValueError``); ``None`` without 3D."""
    def to_dict(self) -> Dict[str, Any]:
        """Exactly the JSON Lines entry ``monohand run`` writes for this hand."""

class Models:
    """The networks, loaded once and shared by sessions."""

    def __init__(
        self,
        hands: int = 2,
        tracking: bool = True,
        model_dir: Optional[Union[str, PathLike[str]]] = None,
        heads: bool = False,
        mirror_pass: bool = True,
        precision: str = "f32",
    ) -> None: ...
    @property
    def precision(self) -> str: ...
    @property
    def hands(self) -> int: ...
    @property
    def tracking(self) -> bool: ...
    @property
    def mirror_pass(self) -> bool: ...

Image = npt.NDArray[np.uint8]

class HandSize:
    """A person's hand measured once (``monohand run --save-hand``) or by ruler; both hands' size."""

    @staticmethod
    def load(path: Union[str, PathLike[str]]) -> HandSize: ...
    @staticmethod
    def from_length(length_mm: float) -> HandSize:
        """A ruler's hand length: the hand flat, wrist crease to the end of the middle finger."""
    def save(self, path: Union[str, PathLike[str]]) -> None: ...
    @property
    def scale(self) -> float: ...
    @property
    def scale_sigma(self) -> Optional[float]: ...
    @property
    def hand_length_mm(self) -> float: ...
    @property
    def source(self) -> str: ...
    @property
    def side(self) -> Optional[str]: ...
    @property
    def frames(self) -> List[int]: ...
    @property
    def bone_lengths_mm(self) -> Optional[List[Optional[float]]]: ...

class Session:
    """Frames in (``(H, W, 3)`` uint8 RGB, one per camera), tracked absolute 3D hands out."""

    def __init__(
        self,
        cameras: Optional[Union[Camera, Sequence[Camera]]] = None,
        hands: int = 2,
        tracking: bool = True,
        model_dir: Optional[Union[str, PathLike[str]]] = None,
        smoothing: bool = False,
        heads: bool = False,
        detect_every: int = 10,
        models: Optional[Models] = None,
        hand_scale: Optional[float] = None,
        mirror_pass: bool = True,
        rectify_crops: str = "off",
        precision: str = "auto",
        hand: Optional[Union[HandSize, str, PathLike[str]]] = None,
        rerun: Optional[Union[str, PathLike[str]]] = None,
        rerun_image_scale: float = 1.0,
        fitted_crops: bool = True,
    ) -> None:
        """``hand``: the person's hand size (a ``HandSize`` or a hand file's path).
        ``precision``: ``"f32"``, ``"int8"`` or ``"auto"`` (int8 with 5 cameras or more, else
        f32; with ``models``, the models' precision).
        ``fitted_crops``: with several calibrated cameras, each view's crops come from the
        hand fitted in 3D in the frame before (``False``: each view finds its hands itself).
        ``rerun``: a Rerun recording (.rrd) of every frame the session processes or
        tracks (cameras, images scaled by ``rerun_image_scale``, 2D keypoints, 3D hands,
        each hand's distance), complete when the session is closed."""
    def process(self, image: Union[Image, List[Image]], time_s: Optional[float] = None) -> List[Hand]:
        """One frame (default time: 30 fps); its hands."""
    def process_dict(self, image: Union[Image, List[Image]], time_s: Optional[float] = None) -> Dict[str, Any]:
        """One frame; the whole JSON Lines record (hands, heads) as a dict."""
    def notes(self) -> List[str]: ...
    @property
    def cameras(self) -> List[Camera]: ...
    def track(
        self,
        path: Union[
            str,
            PathLike[str],
            Sequence[Union[str, PathLike[str]]],
            Iterable[Union[Image, List[Image], Tuple[Union[Image, List[Image]], float], Frame]],
        ],
        max_frames: Optional[int] = None,
        offline: bool = False,
        sync: Union[None, str, Sequence[float]] = None,
        lerobot: Union[None, str, PathLike[str]] = None,
        lerobot_task: str = "human hand",
    ) -> FrameStream: ...
    def close(self) -> None: ...
    def __enter__(self) -> Session: ...
    def __exit__(self, *args: Any) -> bool: ...

class Lifter:
    """2D keypoints made elsewhere in, absolute 3D out, frame after frame."""

    def __init__(
        self,
        camera: Union[Camera, Sequence[Camera]],
        tracking: bool = True,
        hand_scale: Optional[float] = None,
        hand: Optional[Union[HandSize, str, PathLike[str]]] = None,
    ) -> None: ...
    def lift(self, keypoints_2d: npt.NDArray[np.float64], side: str = "right") -> Hand: ...

class TrackedFrame:
    @property
    def index(self) -> int: ...
    @property
    def time_s(self) -> Optional[float]: ...
    @property
    def hands(self) -> List[Hand]: ...
    @property
    def error(self) -> Optional[str]: ...
    @property
    def cameras(self) -> List[Dict[str, Any]]: ...
    def to_dict(self) -> Dict[str, Any]: ...

class FrameStream:
    def __iter__(self) -> Iterator[TrackedFrame]: ...
    def __next__(self) -> TrackedFrame: ...
    def notes(self) -> List[str]: ...
    @property
    def summary(self) -> Optional[Dict[str, Any]]: ...
    def close(self) -> None: ...
    def __enter__(self) -> FrameStream: ...
    def __exit__(self, *args: Any) -> bool: ...

class Frame:
    """A decoded frame; ``image`` wraps the decoder's buffer without a copy."""

    index: int
    time_s: float
    image: npt.NDArray[np.uint8]

class VideoReader:
    """The frames of a video file, decoded by ffmpeg."""

    def __init__(self, path: str) -> None: ...
    @property
    def fps(self) -> float: ...
    @property
    def size(self) -> Tuple[int, int]:
        """``(width, height)``."""
    def __iter__(self) -> VideoReader: ...
    def __next__(self) -> Frame: ...
    def close(self) -> None: ...
    def __enter__(self) -> VideoReader: ...
    def __exit__(self, *args: Any) -> bool: ...

def fetch_models(model_dir: Optional[Union[str, PathLike[str]]] = None) -> str:
    """Makes sure the weights are cached (pip on first use); returns the cache folder."""

def lerobot_dataset(
    parts: Sequence[Union[str, PathLike[str]]], out: Union[str, PathLike[str]]
) -> Dict[str, Any]:
    """One LeRobot v3 dataset of one-episode datasets (``Session.track(lerobot=...)``'s):
    ``episodes``, ``frames``, ``left_out`` (``(part, reason)`` pairs)."""

def calibrate(
    input: Optional[Union[str, PathLike[str], List[Union[str, PathLike[str]]]]] = None,
    *,
    views: Optional[List[Union[str, PathLike[str]]]] = None,
    board: str,
    square_mm: float,
    output: Optional[Union[str, PathLike[str]]] = None,
    model: str = "standard",
    opencv_yaml: bool = False,
    report: Optional[Union[str, PathLike[str]]] = None,
    max_views: int = 40,
    subpix_window: Optional[int] = None,
    keep_all_views: bool = False,
) -> Dict[str, Any]:
    """A camera's (``input``) or a rig's (``views``, one per camera) calibration from frames
    of a chessboard with ``board`` inner corners (``"9x6"``) of ``square_mm``, as
    ``monohand calibrate``; files written when ``output`` is given. ``model`` is the lens
    model estimated: ``"standard"`` (k1 k2 p1 p2 k3), ``"rational"`` (k1..k6 with p1 p2)
    or ``"fisheye"`` (OpenCV's ``cv::fisheye``, k1..k4, for lenses wider than about 120
    degrees). Returns ``cameras`` (each camera's JSON), ``summary``, ``report`` (Markdown)
    and ``written``."""
