"""The driver: bundle the scene, check the workers' lumo, one Dask task per chunk of samples,
check and keep each film as it arrives, merge."""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from . import worker as remote
from .cli import BUNDLE_OVERRIDES, IMAGE_EXTENSIONS
from .film import Expected, FilmRejected, check_film

# How many times the driver submits one chunk (the first time included) before it gives up:
# after Dask's own retries are spent, or when the film that came back is not the right one.
MAX_SUBMISSIONS = 4
# Fold the accepted films into one merged film at least every so many chunks, so that the
# final `lumo merge` reads a bounded number of files whatever the chunk count.
FOLD_EVERY = 64


class Failure(Exception):
    """Ends the job with a message and an exit code (2 bad input, 1 anything else)."""

    def __init__(self, message: str, code: int = 1):
        super().__init__(message)
        self.code = code


def log(message: str) -> None:
    print(f"lumo-dask: {message}", file=sys.stderr, flush=True)


@dataclass(frozen=True)
class Chunk:
    index: int
    start: int
    end: int

    def __str__(self) -> str:
        return f"chunk {self.index + 1} (samples {self.start}..{self.end})"


def chunks(spp: int, chunk_spp: int) -> list[Chunk]:
    """Sample ranges 0..K, K..2K, … covering 0..spp, the last one shorter."""
    return [
        Chunk(i, start, min(start + chunk_spp, spp))
        for i, start in enumerate(range(0, spp, chunk_spp))
    ]


def run_lumo(cmd: list[str], what: str) -> subprocess.CompletedProcess:
    """Runs a local lumo command; lumo's exit code 2 (bad input) passes through with its
    message, any other failure is exit code 1."""
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, stdin=subprocess.DEVNULL)
    except OSError as e:
        raise Failure(f"cannot run `{cmd[0]}`: {e}") from None
    if proc.returncode != 0:
        message = (proc.stderr or proc.stdout).strip() or f"exit code {proc.returncode}"
        code = 2 if proc.returncode == 2 else 1
        raise Failure(f"{what} failed:\n{message}", code)
    return proc


def resolve_lumo(given: str | None) -> str:
    """The absolute path of the local lumo binary."""
    name = given or "lumo"
    path = shutil.which(name)
    if path is None:
        if given:
            raise Failure(f"--lumo {given}: not found or not executable", 2)
        raise Failure("`lumo` is not on PATH (install it, or pass --lumo PATH)")
    return os.path.abspath(path)


@dataclass
class Bundle:
    data: bytes
    sha256: str
    scene_hash: str
    width: int
    height: int
    files: int


def make_bundle(args: argparse.Namespace, lumo: str, work: Path) -> Bundle:
    """`lumo bundle` of the scene with the overrides baked in."""
    path = work / "bundle.zip"
    cmd = [lumo, "bundle", args.scene]
    for flag, *_ in BUNDLE_OVERRIDES:
        value = getattr(args, flag[2:].replace("-", "_"))
        if value is not None:
            cmd += [flag, str(value)]
    cmd += ["-o", str(path)]
    proc = run_lumo(cmd, f"lumo bundle {args.scene}")
    try:
        info = json.loads(proc.stdout.strip().splitlines()[-1])
        scene_hash, width, height = info["scene_hash"], int(info["width"]), int(info["height"])
    except (ValueError, IndexError, KeyError, TypeError):
        raise Failure(f"`lumo bundle` printed no bundle summary: {proc.stdout.strip()!r}") from None
    data = path.read_bytes()
    return Bundle(
        data=data,
        sha256="sha256:" + hashlib.sha256(data).hexdigest(),
        scene_hash=scene_hash,
        width=width,
        height=height,
        files=int(info.get("files", 0)),
    )


@contextlib.contextmanager
def connect(args: argparse.Namespace):
    """A client of the given scheduler, or of a local cluster (processes on 127.0.0.1)."""
    from distributed import Client, LocalCluster

    if args.scheduler:
        try:
            client = Client(args.scheduler, timeout="30s")
        except (OSError, TimeoutError) as e:
            raise Failure(f"cannot reach the Dask scheduler at {args.scheduler}: {e}") from None
        try:
            yield client
        finally:
            client.close()
        return
    workers = max(1, (os.cpu_count() or 1) // args.threads_per_task)
    cluster = LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def check_workers(client, worker_lumo: str, local: dict) -> dict:
    """`lumo version` on every worker; refuses (exit code 2) any whose lumo differs from the
    driver's. Returns the answers by worker address."""
    answers = client.run(remote.lumo_version, worker_lumo, on_error="return")
    bad = []
    for address, info in sorted(answers.items()):
        if isinstance(info, BaseException):
            bad.append(f"worker {address}: `lumo version` could not run: {info}")
        elif "error" in info:
            bad.append(f"worker {address} ({info['host']}): {info['error']}")
        elif (info["version"], info["build_id"]) != (local["version"], local["build_id"]):
            bad.append(
                f"worker {address} ({info['host']}) runs lumo {info['version']} "
                f"{info['build_id']} ({info['path']})"
            )
    if bad:
        raise Failure(
            f"every worker must run the driver's lumo {local['version']} {local['build_id']} "
            "(films of different builds do not merge):\n  " + "\n  ".join(bad),
            2,
        )
    return answers


class Job:
    def __init__(self, args: argparse.Namespace):
        self.args = args
        self.out = Path(args.output)
        self.t0 = time.monotonic()

    def run(self) -> int:
        args = self.args
        if self.out.suffix.lower() not in IMAGE_EXTENSIONS:
            raise Failure(f"{self.out}: the output must be an .exr, .png, .hdr or .bmp image", 2)
        parent = self.out.parent if str(self.out.parent) else Path(".")
        if not parent.is_dir():
            raise Failure(f"{self.out}: the folder {parent} does not exist", 2)
        self.lumo = resolve_lumo(args.lumo)
        local = remote.lumo_version(self.lumo)
        if "error" in local:
            raise Failure(f"this machine's lumo: {local['error']}")
        self.local = local
        log(f"lumo {local['version']} {local['build_id']} at {self.lumo}")
        with tempfile.TemporaryDirectory(prefix="lumo-dask-") as work:
            self.work = Path(work)
            self.bundle = make_bundle(args, self.lumo, self.work)
            b = self.bundle
            log(
                f"bundled {args.scene}: {b.width}×{b.height}, {b.files} files, "
                f"{len(b.data)} bytes, scene {b.scene_hash}"
            )
            with connect(args) as client:
                return self.render(client)

    def render(self, client) -> int:
        import cloudpickle
        from distributed import as_completed

        args = self.args
        # The workers run this driver's copy of the task code, not an installed one.
        cloudpickle.register_pickle_by_value(remote)
        if args.lumo:
            worker_lumo = args.lumo
            if not args.scheduler:
                worker_lumo = self.lumo
        else:
            worker_lumo = "lumo" if args.scheduler else self.lumo
        try:
            client.wait_for_workers(1, timeout=args.wait_workers)
        except TimeoutError:
            raise Failure(
                f"no worker joined the scheduler {args.scheduler} within "
                f"{args.wait_workers:g} s"
            ) from None
        answers = check_workers(client, worker_lumo, self.local)
        where = args.scheduler or "a local cluster"
        log(f"{len(answers)} workers on {where}, all running the same lumo build")

        expected = Expected(
            scene_hash=self.bundle.scene_hash,
            width=self.bundle.width,
            height=self.bundle.height,
            lumo_version=self.local["version"],
            build_id=self.local["build_id"],
        )
        bundle_future = client.scatter(self.bundle.data, broadcast=True, hash=False)
        todo = chunks(args.spp, args.chunk_spp)
        log(
            f"{args.spp} spp in {len(todo)} chunks of {args.chunk_spp} samples, "
            f"{args.threads_per_task} lumo thread(s) per task"
        )

        # Task starts reported by the workers, by run (a run is one submission of a chunk;
        # Dask runs it again after an error or when its worker is lost).
        topic = f"lumo-dask-{uuid.uuid4().hex}"
        starts: Counter[str] = Counter()
        runs: dict[str, Chunk] = {}
        lock = threading.Lock()

        def on_event(event) -> None:
            msg = event[1] if isinstance(event, tuple) else event
            if not isinstance(msg, dict) or msg.get("event") != "start":
                return
            with lock:
                starts[msg["run"]] += 1
                n = starts[msg["run"]]
                chunk = runs.get(msg["run"])
            if n > 1 and chunk is not None:
                log(f"{chunk} started again on {msg.get('worker')} (run {n} of this submission)")

        client.subscribe_topic(topic, on_event)

        submissions: Counter[int] = Counter()
        banned: set[str] = set()
        live: dict[str, tuple[Chunk, object]] = {}  # submitted and not yet back, by key
        counts = Counter()

        def submit(chunk: Chunk):
            nonlocal bundle_future
            submissions[chunk.index] += 1
            run_id = (
                f"lumo-chunk-{chunk.index}-{chunk.start}-{chunk.end}-"
                f"{submissions[chunk.index]}-{uuid.uuid4().hex[:8]}"
            )
            if bundle_future.status != "finished":
                log("the bundle was lost with its workers: sending it again")
                bundle_future = client.scatter(self.bundle.data, broadcast=True, hash=False)
            restrict = {}
            if banned:
                allowed = [w for w in client.nthreads() if w not in banned]
                if not allowed:
                    raise Failure(
                        "every worker left has returned a wrong film: " + ", ".join(sorted(banned))
                    )
                restrict = {"workers": allowed, "allow_other_workers": False}
            with lock:
                runs[run_id] = chunk
            future = client.submit(
                remote.render_chunk,
                bundle_future,
                self.bundle.sha256,
                chunk.start,
                chunk.end,
                args.threads_per_task,
                worker_lumo,
                run_id,
                topic,
                args.light_sampler,
                key=run_id,
                pure=False,
                retries=args.retries,
                **restrict,
            )
            live[future.key] = (chunk, future)
            return future

        def again(chunk: Chunk, why: str, queue) -> None:
            if submissions[chunk.index] >= MAX_SUBMISSIONS:
                raise Failure(f"{chunk}: {why}; giving up after {MAX_SUBMISSIONS} submissions")
            log(f"{chunk}: {why}; submitting it again")
            counts["resubmitted"] += 1
            queue.add(submit(chunk))

        queue = as_completed([submit(c) for c in todo])
        accepted: dict[int, Path] = {}
        used: set[str | None] = set()  # workers whose films were accepted
        pending: list[Path] = []  # accepted films not yet folded into acc
        acc = self.work / "merged.npz"
        last_write = time.monotonic()
        try:
            for future in queue:
                chunk, _ = live.pop(future.key)
                if future.status != "finished":
                    try:
                        error = future.exception()
                    except Exception as e:  # cancelled: the scheduler lost it
                        error = e
                    future.release()
                    counts["failed"] += 1
                    again(chunk, f"failed: {type(error).__name__}: {error}", queue)
                    continue
                try:
                    result = future.result()
                except Exception as e:  # its data was lost with its worker before it came
                    future.release()
                    counts["failed"] += 1
                    again(chunk, f"its film could not be fetched: {type(e).__name__}: {e}", queue)
                    continue
                future.release()
                try:
                    check_film(result["film"], expected, chunk.start, chunk.end)
                except FilmRejected as e:
                    counts["rejected"] += 1
                    bad_worker = result.get("worker")
                    if bad_worker:
                        banned.add(bad_worker)
                    again(chunk, f"rejected the film from worker {bad_worker}: {e}", queue)
                    continue
                path = self.work / f"chunk-{chunk.index:06d}-{chunk.start}-{chunk.end}.npz"
                path.write_bytes(result["film"])
                accepted[chunk.index] = path
                used.add(result.get("worker"))
                pending.append(path)
                log(
                    f"{chunk} accepted from worker {result.get('worker')} "
                    f"({result.get('seconds', 0):.1f} s) [{len(accepted)}/{len(todo)}]"
                )
                if len(accepted) == len(todo):
                    break
                now = time.monotonic()
                if now - last_write >= args.progress_every or len(pending) >= FOLD_EVERY:
                    self.fold(acc, pending, partial=True)
                    pending = []
                    last_write = time.monotonic()
                    spp = sum(c.end - c.start for c in todo if c.index in accepted)
                    log(
                        f"wrote partial {self.out} ({len(accepted)}/{len(todo)} chunks, "
                        f"{spp} of {args.spp} spp)"
                    )
        except BaseException:
            with contextlib.suppress(Exception):
                client.cancel([f for _, f in live.values()])
            raise
        finally:
            with contextlib.suppress(Exception):
                client.unsubscribe_topic(topic)

        self.fold(acc, pending, partial=False)
        seconds = time.monotonic() - self.t0
        with lock:
            reruns = sum(n - 1 for n in starts.values() if n > 1)
        plural = lambda n, word: f"{n} {word}" + ("" if n == 1 else "s")  # noqa: E731
        log(
            f"done: {self.out} ({self.bundle.width}×{self.bundle.height}, {args.spp} spp) from "
            f"{plural(len(todo), 'chunk')} on {plural(len(used), 'worker')} in {seconds:.1f} s; "
            f"retries: {plural(reruns, 'task run')} repeated by Dask, "
            f"{plural(counts['resubmitted'], 'chunk')} resubmitted ({counts['failed']} failed, "
            f"{counts['rejected']} rejected)"
        )
        return 0

    def fold(self, acc: Path, pending: list[Path], partial: bool) -> None:
        """Merges the running merged film and the newly accepted films into OUT (and, while
        the job runs, into the new running merged film)."""
        inputs = ([acc] if acc.exists() else []) + pending
        cmd = [self.lumo, "merge", *map(str, inputs), "-o", str(self.out)]
        if partial:
            nxt = acc.with_name("merged.next.npz")
            cmd += ["--allow-partial", "--film", str(nxt)]
            run_lumo(cmd, "lumo merge (progress image)")
            os.replace(nxt, acc)
            for p in pending:
                p.unlink()
        else:
            proc = run_lumo(cmd, "lumo merge")
            last = proc.stderr.strip().splitlines()[-1:] if proc.stderr else []
            for line in last:
                log(f"lumo: {line}")


def run(args: argparse.Namespace) -> int:
    try:
        return Job(args).run()
    except Failure as e:
        print(f"lumo-dask: error: {e}", file=sys.stderr, flush=True)
        return e.code
    except KeyboardInterrupt:
        print("lumo-dask: interrupted", file=sys.stderr, flush=True)
        return 130
    except Exception as e:  # the cluster went away, or something we did not foresee
        print(f"lumo-dask: error: {type(e).__name__}: {e}", file=sys.stderr, flush=True)
        return 1
