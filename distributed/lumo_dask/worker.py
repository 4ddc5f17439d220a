"""What runs on the Dask workers: `lumo version` and the render of one chunk of samples.

Standard library only. The driver registers this module with cloudpickle to be pickled by
value, so a worker needs Dask and a `lumo` binary, not lumo-dask itself, and always runs the
driver's copy of this code.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import stat
import subprocess
import tempfile
import time
import zipfile
from pathlib import Path, PurePosixPath

# How much of lumo's stderr a failure message keeps.
STDERR_TAIL = 2000


def _tail(text: str, limit: int = STDERR_TAIL) -> str:
    text = text.strip()
    return text if len(text) <= limit else "…" + text[-limit:]


def lumo_version(lumo: str) -> dict:
    """Runs `lumo version` here. Returns `{"version", "build_id", "path", "host"}`, or
    `{"error", "host"}` when lumo cannot be run or answers something else."""
    host = socket.gethostname()
    path = shutil.which(lumo)
    if path is None:
        where = "on PATH" if os.sep not in lumo else "or not executable"
        return {"host": host, "error": f"`{lumo}` not found {where}"}
    try:
        proc = subprocess.run(
            [path, "version"],
            capture_output=True,
            text=True,
            stdin=subprocess.DEVNULL,
            timeout=300,
        )
    except (OSError, subprocess.SubprocessError) as e:
        return {"host": host, "error": f"cannot run `{path} version`: {e}"}
    if proc.returncode != 0:
        return {
            "host": host,
            "error": f"`{path} version` failed with exit code {proc.returncode}: "
            + _tail(proc.stderr or proc.stdout, 500),
        }
    try:
        info = json.loads(proc.stdout.strip().splitlines()[-1])
        version, build_id = str(info["version"]), str(info["build_id"])
    except (ValueError, IndexError, KeyError, TypeError):
        return {
            "host": host,
            "error": f"`{path} version` printed no version JSON: {_tail(proc.stdout, 300)!r}",
        }
    return {"host": host, "version": version, "build_id": build_id, "path": path}


def sha256_file(path: Path) -> str:
    """`sha256:<hex>` of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return "sha256:" + h.hexdigest()


def safe_extract(zip_path: Path, dest: Path) -> None:
    """Extracts a bundle, refusing members that would land outside `dest` (absolute paths,
    `..`, drive letters, backslashes) and symbolic links."""
    with zipfile.ZipFile(zip_path) as z:
        for info in z.infolist():
            name = info.filename
            parts = PurePosixPath(name).parts
            mode = info.external_attr >> 16
            if (
                name.startswith("/")
                or "\\" in name
                or ".." in parts
                or (parts and ":" in parts[0])
            ):
                raise RuntimeError(f"bundle member {name!r} would land outside its folder")
            if stat.S_ISLNK(mode):
                raise RuntimeError(f"bundle member {name!r} is a symbolic link")
        z.extractall(dest)


def _worker():
    """The Dask worker running this code, or None outside one (unit tests)."""
    try:
        from distributed import get_worker

        return get_worker()
    except (ImportError, ValueError):
        return None


def render_command(
    exe: str, scene: Path, start: int, end: int, film: Path, threads: int, light_sampler: str
) -> list[str]:
    """The `lumo render` of sample indices `start..end` into partial film `film`."""
    return [
        exe,
        "render",
        str(scene),
        "--samples",
        f"{start}..{end}",
        "--film",
        str(film),
        "--threads",
        str(threads),
        "--light-sampler",
        light_sampler,
        "-q",
    ]


def render_chunk(
    bundle: bytes,
    bundle_sha256: str,
    start: int,
    end: int,
    threads: int,
    lumo: str,
    run_id: str,
    topic: str | None = None,
    light_sampler: str = "auto",
) -> dict:
    """Renders sample indices `start..end` of the bundled scene in a temporary folder and
    returns the partial film's bytes with where and how long it took.

    The bundle is written to disk and its SHA-256 checked before anything is extracted."""
    t0 = time.monotonic()
    worker = _worker()
    address = getattr(worker, "address", None)
    if worker is not None and topic:
        worker.log_event(topic, {"event": "start", "run": run_id, "worker": address})
    root = getattr(worker, "local_directory", None)
    where = f"worker {address}" if address else f"host {socket.gethostname()}"
    exe = shutil.which(lumo)
    if exe is None:
        raise RuntimeError(f"{where}: lumo `{lumo}` not found")
    with tempfile.TemporaryDirectory(prefix="lumo-dask-", dir=root) as tmp:
        tmp = Path(tmp)
        zip_path = tmp / "bundle.zip"
        zip_path.write_bytes(bundle)
        got = sha256_file(zip_path)
        if got != bundle_sha256:
            raise RuntimeError(
                f"{where}: the bundle arrived damaged ({got}, expected {bundle_sha256})"
            )
        scene_dir = tmp / "scene"
        safe_extract(zip_path, scene_dir)
        zip_path.unlink()
        scene = scene_dir / "scene.json"
        if not scene.is_file():
            raise RuntimeError(f"{where}: the bundle has no scene.json at its root")
        film = tmp / "part.npz"
        cmd = render_command(exe, scene, start, end, film, threads, light_sampler)
        proc = subprocess.run(
            cmd, capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=tmp
        )
        if proc.returncode != 0:
            raise RuntimeError(
                f"{where}: `lumo render --samples {start}..{end}` failed with exit code "
                f"{proc.returncode}: {_tail(proc.stderr or proc.stdout)}"
            )
        if not film.is_file():
            raise RuntimeError(
                f"{where}: `lumo render --samples {start}..{end}` wrote no film"
            )
        data = film.read_bytes()
    return {
        "film": data,
        "worker": address,
        "host": socket.gethostname(),
        "seconds": time.monotonic() - t0,
    }
