"""The `lumo-dask` command line."""

from __future__ import annotations

import argparse
import sys

from . import __version__

IMAGE_EXTENSIONS = (".exr", ".png", ".hdr", ".bmp")

# (flag, type, metavar, help) of the render overrides handed to `lumo bundle`, which bakes them into
# the bundled scene.
BUNDLE_OVERRIDES = (
    ("--env", str, "FILE", "light the scene with this equirectangular HDR image (.exr, .hdr)"),
    ("--env-strength", float, "S", "multiplies the environment's radiance"),
    ("--env-rotation", float, "DEG", "rotates the --env image about +y, in degrees"),
    ("--width", int, "W", "image width in pixels"),
    ("--height", int, "H", "image height in pixels"),
    ("--seed", int, "S", "random seed"),
    ("--max-depth", int, "D", "maximum path depth (1 = emitters only, 2 = direct light)"),
    ("--integrator", str, "I", "light-transport algorithm: path, raycast"),
    ("--sampler", str, "K", "sample sequence: sobol, independent"),
    ("--camera", str, "C", "glTF input: the camera, by name or index"),
    ("--lights", str, "L", "legacy .txt scenes: keep, drop or auto"),
)

# `lumo render --light-sampler`: a render setting, not a scene's, so it is passed to every task
# rather than baked into the bundle.
LIGHT_SAMPLERS = ("auto", "power", "tree")


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, found {value}")
    return value


def non_negative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be at least 0, found {value}")
    return value


def non_negative_float(text: str) -> float:
    value = float(text)
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be at least 0, found {text}")
    return value


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="lumo-dask",
        description="Render a lumo scene on a Dask cluster: one task per chunk of samples, "
        "merged bit for bit as one `lumo render --spp N`.",
        epilog="Exit codes: 0 success, 2 invalid input (lumo's own messages pass through), "
        "1 other failures.",
    )
    p.add_argument("scene", metavar="SCENE", help="the scene (any input `lumo render` reads)")
    p.add_argument("--spp", type=positive_int, required=True, help="samples per pixel in all")
    p.add_argument(
        "--chunk-spp",
        type=positive_int,
        required=True,
        metavar="K",
        help="samples per task: chunks 0..K, K..2K, … (the last one shorter)",
    )
    p.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUT",
        help="output image (.exr, .png, .hdr, .bmp); also rewritten with the samples so far "
        "while the job runs",
    )
    p.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="a running Dask scheduler (default: a local cluster on this machine)",
    )
    p.add_argument(
        "--lumo",
        metavar="PATH",
        help="the lumo binary, here and on every worker (default: `lumo` from each "
        "machine's PATH)",
    )
    p.add_argument(
        "--threads-per-task",
        type=positive_int,
        default=1,
        metavar="T",
        help="`lumo render --threads` of each task (default 1: one task per Dask thread)",
    )
    p.add_argument(
        "--retries",
        type=non_negative_int,
        default=3,
        metavar="R",
        help="Dask retries of a task that fails (default 3)",
    )
    p.add_argument(
        "--progress-every",
        type=non_negative_float,
        default=10.0,
        metavar="SECONDS",
        help="rewrite OUT with the samples so far at most this often (default 10; 0: after "
        "every chunk)",
    )
    p.add_argument(
        "--wait-workers",
        type=non_negative_float,
        default=120.0,
        metavar="SECONDS",
        help="how long to wait for the first worker to join the scheduler (default 120)",
    )
    p.add_argument(
        "--light-sampler",
        choices=LIGHT_SAMPLERS,
        default="auto",
        help="`lumo render --light-sampler` of every task: how next-event estimation picks a "
        "light (default auto: the light tree from 3 finite lights on); part of each film's "
        "header, so films made otherwise are never merged in",
    )
    g = p.add_argument_group("render overrides (baked into the bundled scene by `lumo bundle`)")
    for flag, kind, metavar, text in BUNDLE_OVERRIDES:
        g.add_argument(flag, type=kind, metavar=metavar, help=text)
    p.add_argument("--version", action="version", version=f"lumo-dask {__version__}")
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    from .driver import run

    return run(args)


if __name__ == "__main__":
    sys.exit(main())
