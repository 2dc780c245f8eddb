"""Type stubs of the native module (crates/python). The public API is the scene_gen package."""

from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union, final

__all__ = ["__version__", "Camera", "Dataset", "Scene", "catalog_json", "categories_json", "evaluate", "generate", "optimize", "optimize_config", "render", "score_candidates", "seeds"]

__version__: str

_Progress = Optional[Callable[[int, int], Any]]
_PoseTuple = Tuple[float, float, Optional[float], float, Optional[float], Optional[float]]

@final
class Camera:
    def __new__(cls, text: str) -> "Camera": ...
    @staticmethod
    def from_json(text: str) -> "Camera": ...
    def spec_json(self) -> str: ...
    @property
    def sensor(self) -> str: ...
    def resolution(self, max_width: Optional[int] = None) -> Tuple[int, int]: ...

@final
class Scene:
    @property
    def seed(self) -> int: ...
    def manifest_json(self) -> str: ...
    def options_json(self) -> str: ...
    def export(self, out: str, format: str, python: str) -> List[str]: ...
    def walk(
        self, height_m: Optional[float] = None
    ) -> Tuple[List[Tuple[float, float, float, float, float]], List[Tuple[int, int, float]]]: ...

@final
class Dataset:
    def __new__(
        cls,
        out: str,
        camera: Camera,
        seeds: str,
        lighting: str = "both",
        frames: Optional[int] = None,
        every: Optional[int] = None,
        max_width: Optional[int] = None,
        quality: str = "standard",
        envelope: Optional[str] = None,
        min_room: Optional[float] = None,
        rooms: Optional[str] = None,
        furniture: Optional[str] = None,
        raw: bool = False,
    ) -> "Dataset": ...
    @staticmethod
    def open(out: str) -> "Dataset": ...
    @property
    def out(self) -> str: ...
    def seeds(self) -> List[int]: ...
    def image_size(self) -> Tuple[int, int]: ...
    def spec_json(self) -> str: ...
    def init(self) -> None: ...
    def run_seed(self, seed: int, progress: _Progress = None) -> Tuple[int, int, int]: ...
    def run_shard(self, index: int = 0, count: int = 1, progress: _Progress = None) -> Tuple[int, int, int]: ...
    def missing_seeds(self) -> List[int]: ...
    def merge(self) -> List[str]: ...

def generate(
    seed: int,
    envelope: Optional[str] = None,
    min_room: Optional[float] = None,
    rooms: Optional[str] = None,
    furniture: Optional[str] = None,
) -> Scene: ...
def render(
    scene: Scene,
    camera: Camera,
    poses: Optional[Sequence[_PoseTuple]] = None,
    poses_file: Optional[str] = None,
    frames: int = 1,
    lighting: str = "day",
    quality: str = "standard",
    max_width: Optional[int] = None,
    progress: _Progress = None,
) -> List[Dict[str, Any]]: ...
def evaluate(
    camera: Camera,
    seeds: Sequence[int],
    frames: Optional[int] = None,
    max_width: Optional[Union[int, str]] = None,
    detector: Optional[str] = None,
    envelope: Optional[str] = None,
    min_room: Optional[float] = None,
    rooms: Optional[str] = None,
    furniture: Optional[str] = None,
    progress: _Progress = None,
) -> str: ...
def optimize_config(
    config: Optional[str] = None,
    envelope: Optional[str] = None,
    min_room: Optional[float] = None,
    rooms: Optional[str] = None,
    furniture: Optional[str] = None,
) -> str: ...
def score_candidates(config_json: str, specs_json: Sequence[str]) -> List[Tuple[float, float, float]]: ...
def optimize(
    out: str,
    config_json: str,
    method: str = "ga",
    score_batch: Optional[Callable[[List[str]], Sequence[Tuple[float, float, float]]]] = None,
    progress: _Progress = None,
    stop_after: Optional[int] = None,
) -> str: ...
def catalog_json() -> str: ...
def seeds(text: str) -> List[int]: ...
def categories_json() -> str: ...
