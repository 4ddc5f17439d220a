"""Type stubs of lumo's extension module (``lumo._lumo``), re-exported by ``lumo``."""

import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal, Optional, Union, overload

import numpy as np
import numpy.typing as npt

_Path = Union[str, os.PathLike[str]]
_Image = npt.NDArray[np.float32]
_Pass = Union[npt.NDArray[np.float32], npt.NDArray[np.uint32]]
_ToneMap = Literal["clamp", "aces"]
_Lights = Literal["keep", "drop", "auto"]

__version__: str
"""lumo's version."""

build_id: str
"""``sha256:`` and the SHA-256 of this extension module's file: the build films rendered from
Python carry. A film from the ``lumo`` command is another build (``lumo.merge`` refuses to mix
them)."""

class SceneError(ValueError):
    """A scene that is not valid, or an override that does not fit it. ``str(e)`` is the
    report ``lumo validate`` prints."""

    diagnostics: list[Diagnostic]
    """Every problem found."""
    file: str
    """The scene file (or ``<dict>``)."""

class RenderCancelled(Exception):
    """A render stopped because its progress callback returned False."""

    result: RenderResult
    """What it had rendered: the whole passes finished before it stopped."""

class LumoWarning(UserWarning):
    """Something lumo dropped or approximated while loading or building a scene."""

class Diagnostic:
    """One problem in a scene: where it is, what is wrong and how to fix it.
    ``str(d)`` is the line ``lumo validate`` prints."""

    @property
    def file(self) -> Optional[str]:
        """The scene file (or ``<dict>``)."""
    @property
    def line(self) -> Optional[int]:
        """1-based line in the file, when the problem has a place in its text."""
    @property
    def column(self) -> Optional[int]:
        """1-based column, with ``line``."""
    @property
    def path(self) -> str:
        """JSON path of the value at fault (``objects[3].sphere.radius``); empty when the
        problem has no place in the JSON."""
    @property
    def message(self) -> str:
        """What is wrong."""
    @property
    def help(self) -> Optional[str]:
        """How to fix it, when there is an obvious fix."""

class Scene:
    """A scene, read and validated, with every mesh and image it references in memory.
    Immutable: overrides make a new scene sharing the meshes and images."""

    @staticmethod
    def from_dict(scene: Mapping[str, Any], base_dir: Optional[_Path] = None) -> Scene:
        """A scene from a dict in lumo's scene JSON format; relative paths resolve against
        ``base_dir`` (default: the working directory). Raises :class:`SceneError`."""
    def to_dict(self) -> dict[str, Any]:
        """The scene as a dict in lumo's scene JSON format."""
    def to_json(self) -> str:
        """The scene as lumo scene JSON text."""
    def with_overrides(self, overrides: Mapping[str, Any]) -> Scene:
        """A new scene with values replaced by JSON path (``"materials.red.base_color"``,
        ``"objects[2].sphere.radius"``, ``"render.spp"``), validated again. Raises
        :class:`SceneError` naming the path of an override that names nothing or does not
        fit."""
    def content_hash(self) -> str:
        """A hash of what the render of the scene depends on, as partial films record it."""
    @property
    def file(self) -> str:
        """The input file (or ``<dict>``)."""
    @property
    def base_dir(self) -> str:
        """The folder relative paths in the scene resolve against."""
    @property
    def kind(self) -> Literal["json", "legacy", "gltf"]:
        """What the input was."""
    @property
    def files(self) -> list[str]:
        """Every file read to load the scene, the input first."""
    @property
    def warnings(self) -> list[str]:
        """Non-fatal problems found while reading the input."""
    @property
    def width(self) -> int:
        """Image width in pixels."""
    @property
    def height(self) -> int:
        """Image height in pixels."""
    @property
    def spp(self) -> int:
        """Samples per pixel the scene asks for."""
    @property
    def seed(self) -> int:
        """The scene's random seed."""

class Stats:
    """What a render did."""

    @property
    def spp(self) -> int:
        """Mean samples per pixel taken (rounded)."""
    @property
    def samples(self) -> int:
        """Samples taken in all."""
    @property
    def new_samples(self) -> int:
        """Samples this call took."""
    @property
    def seconds(self) -> float:
        """Wall time of the render."""
    @property
    def samples_per_second(self) -> float:
        """Samples this call took per second."""
    @property
    def rays(self) -> int:
        """Rays cast."""
    @property
    def dropped_samples(self) -> int:
        """Samples that were NaN or infinite and were dropped."""
    @property
    def estimated_error(self) -> float:
        """√(estimated relative MSE) from the samples' variance."""
    @property
    def estimated_rmse(self) -> float:
        """RMSE predicted from the samples' variance."""

class Film:
    """A partial film: the exact sums of some samples of some pixels of one render; films of
    one scene and build merge bit for bit (:func:`merge`)."""

    @staticmethod
    def read(path: _Path) -> Film:
        """Reads and checks a ``.npz`` partial film (``ValueError`` for a bad file,
        ``OSError`` for one that cannot be read)."""
    def write(self, path: _Path) -> None:
        """Writes the film atomically as a ``.npz`` partial film."""
    def image(self) -> _Image:
        """The mean radiance of the film's window, (h, w, 3) float32."""
    def passes(self) -> dict[str, _Pass]:
        """The render passes the film holds, by name (new arrays, shaped as
        :attr:`RenderResult.passes`)."""
    def std_error(self) -> _Image:
        """The standard error of each pixel's mean, (h, w, 3) float32."""
    def write_image(self, path: _Path, tonemap: _ToneMap = "clamp") -> None:
        """Writes the film's image at the render's full size, as ``lumo merge -o`` does."""
    @property
    def header(self) -> dict[str, Any]:
        """The film's header, as stored in the file."""
    @property
    def width(self) -> int:
        """Full image width of the render."""
    @property
    def height(self) -> int:
        """Full image height of the render."""
    @property
    def crop(self) -> tuple[int, int, int, int]:
        """The window the film covers: (x0, y0, x1, y1)."""
    @property
    def samples(self) -> list[tuple[int, int]]:
        """The sample index ranges every pixel holds."""
    @property
    def spp(self) -> int:
        """Samples per pixel the film holds."""
    @property
    def build_id(self) -> str:
        """The build that rendered it."""
    @property
    def scene_hash(self) -> str:
        """The content hash of the scene it is of."""
    @property
    def complete(self) -> bool:
        """Whether the film makes a complete image."""
    @property
    def gaps(self) -> list[str]:
        """What is missing for a complete image (merged films)."""

class Pixels:
    """The owner of an image's pixel buffer: the ``base`` of the arrays that show it."""

class RenderResult:
    """A finished (or interrupted) render."""

    @property
    def color(self) -> _Image:
        """Mean radiance per pixel, a read-only (H, W, 3) float32 array over the render's own
        buffer (no copy)."""
    @property
    def std_error(self) -> _Image:
        """Standard error of each pixel's mean, read-only (H, W, 3) float32, no copy."""
    @property
    def passes(self) -> dict[str, _Pass]:
        """The render passes asked for (``aov=`` and the scene's ``render.aov``), read-only:
        (H, W, 3) float32 for albedo, normal, position, std_error; (H, W, 2) for uv; (H, W)
        float32 for depth; (H, W) uint32 for object_id and material_id."""
    def denoised(self) -> _Image:
        """The beauty denoised with Open Image Denoise (guided by albedo and normal when
        rendered), a new (H, W, 3) float32 array; ``OSError`` without OIDN."""
    @property
    def stats(self) -> Stats:
        """Counters."""
    @property
    def film(self) -> Film:
        """The render's samples as a partial film."""
    @property
    def interrupted(self) -> bool:
        """Whether the render stopped before its budget was spent."""
    @property
    def spp(self) -> int:
        """Samples per pixel the render holds."""
    @property
    def width(self) -> int:
        """Full image width."""
    @property
    def height(self) -> int:
        """Full image height."""
    @property
    def crop(self) -> tuple[int, int, int, int]:
        """The window rendered: (x0, y0, x1, y1)."""
    @property
    def warnings(self) -> list[str]:
        """What the scene build dropped or approximated."""
    def write(self, path: _Path, tonemap: _ToneMap = "clamp", denoise: bool = False) -> None:
        """Writes the image with its passes (PNG/BMP tone mapped, EXR/HDR linear; passes as
        EXR channels or PNG files beside it), denoised with ``denoise=True``: the bytes
        ``lumo render`` writes for the same scene and settings."""
    def write_std_error(self, path: _Path) -> None:
        """Writes the per-pixel standard error (EXR/HDR)."""
    def _repr_png_(self) -> bytes:
        """The image as PNG bytes, for notebooks."""

def load(
    path: _Path,
    overrides: Optional[Mapping[str, Any]] = None,
    *,
    camera: Union[str, int, None] = None,
    lights: _Lights = "auto",
) -> Scene:
    """Loads a ``.json``, legacy ``.txt`` or ``.gltf``/``.glb`` scene with every file it
    references, applying ``overrides`` (JSON path → value). Raises :class:`SceneError` or
    ``OSError``."""

def render(
    scene: Scene,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    time: Optional[float] = None,
    target_error: Optional[float] = None,
    samples: Optional[tuple[int, int]] = None,
    crop: Optional[tuple[int, int, int, int]] = None,
    progress: Optional[Callable[[int, Optional[int]], Optional[bool]]] = None,
    adaptive: bool = False,
    light_sampler: Literal["auto", "power", "tree"] = "auto",
    aov: Union[str, Sequence[str], None] = None,
) -> RenderResult:
    """Renders ``scene`` with the GIL released. ``progress(done, total)`` is called on the
    calling thread; returning False raises :class:`RenderCancelled`; Ctrl-C raises
    ``KeyboardInterrupt``; either carries the samples so far on ``e.result``."""

def validate(
    scene: Union[_Path, Mapping[str, Any]],
    *,
    base_dir: Optional[_Path] = None,
    camera: Union[str, int, None] = None,
    lights: _Lights = "auto",
) -> list[Diagnostic]:
    """Every problem of a scene file or dict (empty when valid); never raises for bad
    input."""

def convert(
    src: _Path, dst: _Path, *, camera: Union[str, int, None] = None, lights: _Lights = "auto"
) -> list[str]:
    """Converts between lumo JSON, legacy ``.txt`` and glTF by extension; returns the
    warnings."""

def merge(films: Sequence[Film], allow_partial: bool = False) -> Film:
    """Merges partial films of one render bit for bit."""

@overload
def schema(as_text: Literal[False] = False) -> dict[str, Any]: ...
@overload
def schema(as_text: Literal[True]) -> str: ...
