"""lumo from Python: load scenes, render them to numpy arrays, validate, convert, merge films.

>>> import lumo
>>> scene = lumo.load("scenes/cornell.json", {"image.width": 64, "image.height": 64})
>>> result = lumo.render(scene, spp=16)
>>> result.color.shape                      # (H, W, 3) float32: the render's own buffer
(64, 64, 3)
>>> result.write("cornell.png")             # the bytes `lumo render` writes

Renders run with the GIL released; Ctrl-C stops a render within a tile and raises
``KeyboardInterrupt`` with the samples so far on ``e.result``. The guide is ``docs/python.md``
in lumo's repository.
"""

from ._lumo import (
    Diagnostic,
    Film,
    LumoWarning,
    RenderCancelled,
    RenderResult,
    Scene,
    SceneError,
    Stats,
    __version__,
    build_id,
    convert,
    load,
    merge,
    render,
    schema,
    validate,
)

__all__ = [
    "Diagnostic",
    "Film",
    "LumoWarning",
    "RenderCancelled",
    "RenderResult",
    "Scene",
    "SceneError",
    "Stats",
    "__version__",
    "build_id",
    "convert",
    "load",
    "merge",
    "render",
    "schema",
    "validate",
]
