"""Rendering: the CLI's bytes, arrays without a copy, progress, cancel, Ctrl-C, threads,
memory, films and merges."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import lumo
from conftest import CORNELL, ROOT, small

W, H = 32, 24


def film_arrays(path):
    """The arrays of a partial film and its header without the build id."""
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files if k != "header"}
        header = json.loads(bytes(z["header"]))
    header.pop("build_id")
    return arrays, header


def same_film(a, b):
    (xa, ha), (xb, hb) = film_arrays(a), film_arrays(b)
    assert ha == hb
    assert xa.keys() == xb.keys()
    for k in xa:
        assert np.array_equal(xa[k], xb[k]), k


@pytest.mark.parametrize(
    "py_args, cli_args",
    [
        (dict(spp=8, seed=3), ["--spp", "8", "--seed", "3"]),
        (
            dict(samples=(2, 6), crop=(8, 4, 30, 20)),
            ["--samples", "2..6", "--crop", "8,4,30,20"],
        ),
        (dict(spp=4, light_sampler="power", threads=1), ["--spp", "4", "--light-sampler", "power", "--threads", "1"]),
    ],
)
def test_same_bytes_as_the_cli(tmp_path, run_cli, py_args, cli_args):
    scene = lumo.load(CORNELL, small(W, H))
    result = lumo.render(scene, **py_args)
    for ext in ("png", "exr"):
        result.write(tmp_path / f"py.{ext}")
    result.film.write(tmp_path / "py.npz")
    size = ["--width", str(W), "--height", str(H)]
    run_cli("render", CORNELL, *size, *cli_args, "-o", tmp_path / "cli.png", "--film", tmp_path / "cli.npz", "-q")
    run_cli("render", CORNELL, *size, *cli_args, "-o", tmp_path / "cli.exr", "-q")
    for ext in ("png", "exr"):
        assert (tmp_path / f"py.{ext}").read_bytes() == (tmp_path / f"cli.{ext}").read_bytes(), ext
    same_film(tmp_path / "py.npz", tmp_path / "cli.npz")
    # The film's build is the extension's: it differs from the CLI's, and `lumo merge` says so.
    assert lumo.Film.read(tmp_path / "py.npz").build_id == lumo.build_id
    merged = run_cli("merge", tmp_path / "py.npz", tmp_path / "cli.npz", "-o", tmp_path / "m.exr", check=False)
    assert merged.returncode == 2 and "build" in merged.stderr


def test_arrays_are_the_results_own_buffer(cornell):
    result = lumo.render(cornell, spp=2)
    color = result.color
    assert color.shape == (H, W, 3) and color.dtype == np.float32
    assert color.base is not None and not color.flags.owndata
    again = result.color
    assert np.shares_memory(color, again)
    assert color.__array_interface__["data"][0] == again.__array_interface__["data"][0]
    assert not color.flags.writeable, "the render's buffer is read-only; .copy() to change it"
    with pytest.raises(ValueError):
        color[0, 0, 0] = 1.0
    err = result.std_error
    assert err.shape == (H, W, 3) and not err.flags.owndata
    assert not np.shares_memory(err, color)
    # The array keeps the buffer alive after the result is gone.
    del result, again
    import gc

    gc.collect()
    assert np.isfinite(color).all() and color.mean() > 0


def test_stats_and_result(cornell):
    result = lumo.render(cornell, spp=4, seed=1)
    s = result.stats
    assert s.spp == 4 and s.samples == W * H * 4 == s.new_samples
    assert s.seconds > 0 and s.samples_per_second > 0 and s.rays >= s.samples
    assert s.dropped_samples == 0 and 0 < s.estimated_error < 1
    assert not result.interrupted and result.spp == 4
    assert (result.width, result.height, result.crop) == (W, H, (0, 0, W, H))
    png = result._repr_png_()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    assert "4 spp" in repr(result)


def test_crop_renders_the_window(cornell, tmp_path):
    full = lumo.render(cornell, spp=2)
    part = lumo.render(cornell, samples=(0, 2), crop=(4, 2, 20, 14))
    assert part.color.shape == (12, 16, 3)
    assert np.array_equal(part.color, full.color[2:14, 4:20])


def test_bad_arguments():
    scene = lumo.load(CORNELL, small(8, 8))
    with pytest.raises(ValueError, match="spp"):
        lumo.render(scene, spp=0)
    with pytest.raises(ValueError, match="empty"):
        lumo.render(scene, samples=(4, 2))
    with pytest.raises(ValueError, match="not inside"):
        lumo.render(scene, samples=(0, 1), crop=(0, 0, 9, 8))
    with pytest.raises(ValueError, match="fixed sample ranges"):
        lumo.render(scene, samples=(0, 1), time=1.0)
    with pytest.raises(ValueError, match="light_sampler"):
        lumo.render(scene, spp=1, light_sampler="sun")
    with pytest.raises(TypeError):
        lumo.render("scenes/cornell.json", spp=1)


def test_time_and_error_budgets(cornell):
    seen = []
    result = lumo.render(cornell, time=0.3, progress=lambda done, total: seen.append(total))
    assert set(seen) == {None}, "an open-ended render has no total"
    assert result.stats.seconds < 2 and result.spp > 0
    result = lumo.render(cornell, target_error=0.5, spp=4096)
    assert result.stats.estimated_error <= 0.5 and result.spp < 4096


def test_progress_is_called_on_the_calling_thread(cornell):
    calls = []
    caller = threading.get_ident()

    def progress(done, total):
        calls.append((done, total, threading.get_ident()))

    lumo.render(cornell, spp=64, progress=progress)
    assert calls
    assert all(t == caller for _, _, t in calls)
    assert all(total == W * H * 64 for _, total, _ in calls)
    done = [d for d, _, _ in calls]
    assert done == sorted(done) and done[-1] == W * H * 64


def test_cancel_from_the_callback(cornell):
    scene = cornell.with_overrides(small(64, 64))
    stopped_at = []

    def progress(done, total):
        if done >= 2 * 64 * 64:  # the first pass is in
            stopped_at.append(time.monotonic())
            return False
        return None

    start = time.monotonic()
    with pytest.raises(lumo.RenderCancelled) as e:
        lumo.render(scene, spp=1 << 20, progress=progress)
    assert stopped_at and time.monotonic() - stopped_at[0] < 3.0
    result = e.value.result
    assert result.interrupted and result.spp >= 2
    assert result.color.shape == (64, 64, 3) and np.isfinite(result.color).all()
    assert result.film.spp == result.spp
    assert time.monotonic() - start < 30


def test_an_exception_in_the_callback_stops_the_render(cornell):
    def progress(done, total):
        raise ZeroDivisionError("from the callback")

    start = time.monotonic()
    with pytest.raises(ZeroDivisionError, match="from the callback") as e:
        lumo.render(cornell.with_overrides(small(64, 64)), spp=1 << 20, progress=progress)
    assert time.monotonic() - start < 10
    assert e.value.result.interrupted


CHILD = textwrap.dedent(
    """
    import signal, sys, time, lumo
    # Python leaves SIGINT ignored when it starts ignored (a job started in the background by
    # a shell without job control inherits that); Ctrl-C is what this child is about.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    scene = lumo.load(sys.argv[1], {"image.width": 64, "image.height": 64})
    said = False
    def progress(done, total):
        global said
        if done >= 2 * 64 * 64 and not said:   # the first pass is in
            said = True
            print("rendering", flush=True)
    try:
        lumo.render(scene, spp=1 << 20, progress=progress)
        print("finished", flush=True)
    except KeyboardInterrupt as e:
        r = e.result
        print("interrupted", r.interrupted, r.spp, r.color.shape, float(r.color.mean()) > 0, flush=True)
    """
)


def test_ctrl_c_in_a_child_process_raises_keyboard_interrupt_quickly():
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(CORNELL)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = child.stdout.readline()
        assert line.strip() == "rendering", child.stderr.read()
        time.sleep(0.2)
        sent = time.monotonic()
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=20)
        took = time.monotonic() - sent
    finally:
        child.kill()
        child.wait()
    assert child.returncode == 0, err
    words = out.split()
    assert words[:2] == ["interrupted", "True"], out + err
    assert int(words[2]) >= 2 and words[-1] == "True"
    # Within a tile and the waiting slice; generous for a loaded machine.
    assert took < 3.0, f"KeyboardInterrupt took {took:.2f} s"


def test_two_renders_from_two_threads_at_once():
    scenes = [lumo.load(CORNELL, small(48, 32)) for _ in range(2)]
    alone = [lumo.render(s, spp=16, seed=i).color.copy() for i, s in enumerate(scenes)]
    results = [None, None]
    errors = []
    ticks = [0]
    running = [True]

    def work(i):
        try:
            results[i] = lumo.render(scenes[i], spp=16, seed=i, threads=1)
        except BaseException as e:  # reported below
            errors.append(e)

    def spin():
        while running[0]:
            ticks[0] += 1

    spinner = threading.Thread(target=spin)
    spinner.start()
    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    running[0] = False
    spinner.join()
    assert not errors, errors
    for i in range(2):
        assert np.array_equal(results[i].color, alone[i]), i
    assert not np.array_equal(alone[0], alone[1])
    # The GIL was free while both rendered: another Python thread kept running.
    assert ticks[0] > 1000


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs /proc")
def test_memory_is_flat_over_200_load_and_render_cycles():
    def cycle(i):
        scene = lumo.load(CORNELL, {"image.width": 24, "image.height": 16, "render.seed": i})
        result = lumo.render(scene, spp=1)
        color = result.color
        assert color.shape == (16, 24, 3)
        _ = (result.std_error, result.film, result.stats)

    import gc

    for i in range(20):
        cycle(i)
    gc.collect()
    before = rss_bytes()
    for i in range(200):
        cycle(i)
    gc.collect()
    growth = rss_bytes() - before
    # A leak of one result (image, error image, film: ~50 kB here) per cycle would be ~10 MiB.
    assert growth < 4 * 2**20, f"RSS grew by {growth / 2**20:.1f} MiB over 200 cycles"


def test_merge_of_two_sample_ranges_is_one_render(cornell, tmp_path):
    one = lumo.render(cornell, spp=8)
    a = lumo.render(cornell, samples=(0, 3))
    b = lumo.render(cornell, samples=(3, 8))
    merged = lumo.merge([b.film, a.film])
    assert merged.complete and merged.samples == [(0, 8)]
    assert np.array_equal(merged.image(), one.color)
    assert np.array_equal(merged.std_error(), one.std_error)
    merged.write(tmp_path / "merged.npz")
    one.film.write(tmp_path / "one.npz")
    (xm, hm), (xo, ho) = film_arrays(tmp_path / "merged.npz"), film_arrays(tmp_path / "one.npz")
    for k in xo:
        assert np.array_equal(xm[k], xo[k]), k
    # Read back, films merge the same.
    again = lumo.merge([lumo.Film.read(tmp_path / "merged.npz")])
    assert np.array_equal(again.image(), one.color)
    merged.write_image(tmp_path / "merged.exr")
    one.write(tmp_path / "one.exr")
    assert (tmp_path / "merged.exr").read_bytes() == (tmp_path / "one.exr").read_bytes()


def test_merge_of_windows_and_its_errors(cornell):
    one = lumo.render(cornell, spp=2)
    top = lumo.render(cornell, samples=(0, 2), crop=(0, 0, W, 12))
    bottom = lumo.render(cornell, samples=(0, 2), crop=(0, 12, W, H))
    assert np.array_equal(lumo.merge([top.film, bottom.film]).image(), one.color)
    with pytest.raises(ValueError, match="complete"):
        lumo.merge([top.film])
    partial = lumo.merge([top.film], allow_partial=True)
    assert not partial.complete
    with pytest.raises(ValueError, match="overlap"):
        lumo.merge([one.film, top.film])
    other = lumo.render(cornell.with_overrides({"render.seed": 9}), spp=2)
    with pytest.raises(ValueError, match="seed"):
        lumo.merge([one.film, other.film])
    with pytest.raises(ValueError):
        lumo.merge([])


def test_film_files_are_checked(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a film")
    with pytest.raises(ValueError, match="bad.npz"):
        lumo.Film.read(bad)
    with pytest.raises(OSError):
        lumo.Film.read(tmp_path / "missing.npz")
    result = lumo.render(lumo.load(CORNELL, small(8, 8)), spp=1)
    with pytest.raises(ValueError, match=r"\.npz"):
        result.film.write(tmp_path / "film.exr")
    with pytest.raises(ValueError, match="format"):
        result.write(tmp_path / "image.gif")


def test_result_writes_what_the_scene_says_without_arguments(tmp_path, run_cli):
    scene = lumo.load(CORNELL, {"image.width": 16, "image.height": 16, "render.spp": 3})
    lumo.render(scene).write(tmp_path / "py.png")
    run_cli("render", CORNELL, "--width", "16", "--height", "16", "--spp", "3", "-o", tmp_path / "cli.png", "-q")
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()


