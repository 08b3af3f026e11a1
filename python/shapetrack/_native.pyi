"""Types of the extension module (python/src/*.rs). Arrays cross as native-order bytes; the
package (shapetrack/__init__.py) checks them and makes numpy arrays of them."""

from typing import Any, Callable, Optional

__version__: str

class NativeTracker:
    def __init__(self, config: Optional[str] = None) -> None: ...
    def update(
        self,
        n: int,
        boxes: bytes,
        scores: bytes,
        classes: Optional[bytes],
        masks: Optional[bytes],
        frame: Optional[bytes],
        height: int,
        width: int,
    ) -> dict[str, Any]: ...
    @property
    def frame(self) -> int: ...

class NativeOfflineTracker:
    def __init__(self, config: Optional[str] = None, fps: float = 30.0) -> None: ...
    def push(
        self,
        n: int,
        boxes: bytes,
        scores: bytes,
        classes: Optional[bytes],
        masks: Optional[bytes],
        frame: Optional[bytes],
        height: int,
        width: int,
    ) -> None: ...
    def finish(self, progress: Optional[Callable[[str, float], Any]] = None) -> dict[str, Any]: ...
    @property
    def frames(self) -> int: ...

class NativeDetector:
    def __init__(
        self,
        kind: str,
        boxes: Optional[list[list[tuple[float, float, float, float]]]] = None,
        model: Optional[str] = None,
        segment: Optional[str] = None,
    ) -> None: ...
    def detect(self, frame: bytes, height: int, width: int) -> dict[str, bytes]: ...
    @property
    def name(self) -> str: ...
    @property
    def warning(self) -> Optional[str]: ...

def track_files(
    det: str,
    out: str,
    frames: Optional[str] = None,
    seqinfo: Optional[str] = None,
    offline: bool = False,
    preset_name: Optional[str] = None,
    config: Optional[str] = None,
    fps: Optional[float] = None,
    mots_for_masks: bool = True,
) -> dict[str, Any]: ...
def evaluate(
    gt: str,
    results: str,
    benchmark: str = "MOT15",
    split: str = "train",
    seqs: Optional[list[str]] = None,
    masks: bool = False,
    threshold: float = 0.5,
    allow_missing_results: bool = False,
) -> str: ...
def check_config(config: str) -> None: ...
def image_files(dir: str) -> list[str]: ...
def read_frame(path: str) -> tuple[bytes, int, int]: ...
def detect_files(
    frames: str,
    out: str,
    detector: str = "auto",
    boxes: Optional[str] = None,
    model: Optional[str] = None,
    segment: Optional[str] = None,
) -> tuple[int, int, str, Optional[str]]: ...
def follow_frames(
    frames: bytes,
    n: int,
    height: int,
    width: int,
    mask: bytes,
    init: int,
    config: Optional[str] = None,
    model: Optional[str] = None,
) -> dict[str, Any]: ...
