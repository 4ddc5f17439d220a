"""Unit tests of lumo-dask's parts that need no cluster and no lumo binary:
`python -m unittest discover -s distributed/tests` (with distributed/.venv active).

The end-to-end tests on a real Dask cluster are `tests/dask_cluster.rs`."""

from __future__ import annotations

import hashlib
import io
import json
import os
import stat
import sys
import tempfile
import unittest
import zipfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumo_dask import worker  # noqa: E402
from lumo_dask.cli import parser  # noqa: E402
from lumo_dask.driver import chunks  # noqa: E402
from lumo_dask.film import Expected, FilmRejected, check_film  # noqa: E402

EXPECTED = Expected(
    scene_hash="sha256:" + "ab" * 32,
    width=4,
    height=3,
    lumo_version="0.1.0",
    build_id="sha256:" + "cd" * 32,
)


def film(start=8, end=12, **changes) -> bytes:
    """A film as `lumo render --samples start..end --film` writes it, with header fields or
    arrays replaced by `changes`."""
    h, w = EXPECTED.height, EXPECTED.width
    header = {
        "format": "lumo-partial-film",
        "format_version": 1,
        "lumo_version": EXPECTED.lumo_version,
        "build_id": EXPECTED.build_id,
        "scene_hash": EXPECTED.scene_hash,
        "width": w,
        "height": h,
        "crop": [0, 0, w, h],
        "seed": 0,
        "sampler": "sobol",
        "samples": [[start, end]],
        "target_spp": end,
    }
    arrays = {
        "sum_hi": np.zeros((h, w, 3), "<i8"),
        "sum_lo": np.arange(h * w * 3, dtype="<u8").reshape(h, w, 3),
        "sum_sq_hi": np.zeros((h, w, 3), "<i8"),
        "sum_sq_lo": np.ones((h, w, 3), "<u8"),
        "finite": np.full((h, w), end - start - 1, "<u4"),
        "dropped": np.ones((h, w), "<u4"),
    }
    for key, value in changes.items():
        if key in arrays:
            arrays[key] = value
        else:
            header[key] = value
    buf = io.BytesIO()
    np.savez(buf, header=np.frombuffer(json.dumps(header).encode(), np.uint8), **arrays)
    return buf.getvalue()


class FilmCheck(unittest.TestCase):
    def rejected(self, data: bytes, start=8, end=12) -> str:
        with self.assertRaises(FilmRejected) as caught:
            check_film(data, EXPECTED, start, end)
        return str(caught.exception)

    def test_the_right_film_passes(self):
        header = check_film(film(), EXPECTED, 8, 12)
        self.assertEqual(header["samples"], [[8, 12]])

    def test_another_scene_build_or_version_is_rejected(self):
        self.assertIn("scene", self.rejected(film(scene_hash="sha256:" + "00" * 32)))
        self.assertIn("lumo build", self.rejected(film(build_id="sha256:" + "11" * 32)))
        self.assertIn("lumo version", self.rejected(film(lumo_version="0.2.0")))
        self.assertIn("format", self.rejected(film(format="something-else")))

    def test_other_samples_are_rejected(self):
        self.assertIn("wrong sample ranges [[8, 12]]", self.rejected(film(), 12, 16))
        self.assertIn("sample ranges", self.rejected(film(samples=[[8, 10], [10, 12]])))

    def test_another_resolution_or_a_crop_is_rejected(self):
        self.assertIn("resolution 5×3", self.rejected(film(width=5)))
        self.assertIn("crop window", self.rejected(film(crop=[0, 0, 2, 3])))

    def test_arrays_of_the_wrong_shape_type_or_count_are_rejected(self):
        h, w = EXPECTED.height, EXPECTED.width
        self.assertIn("sum_lo", self.rejected(film(sum_lo=np.zeros((h, w + 1, 3), "<u8"))))
        self.assertIn("finite", self.rejected(film(finite=np.zeros((h, w), "<f4"))))
        finite = np.full((h, w), 3, "<u4")
        finite[2, 1] = 2
        self.assertIn("pixel (1, 2) holds 3 samples", self.rejected(film(finite=finite)))

    def test_garbage_is_rejected(self):
        self.assertIn("not a readable partial film", self.rejected(b"not a zip"))
        self.assertIn("not a readable partial film", self.rejected(film()[:200]))


class Chunks(unittest.TestCase):
    def test_chunks_cover_the_samples_once_the_last_shorter(self):
        got = [(c.start, c.end) for c in chunks(10, 4)]
        self.assertEqual(got, [(0, 4), (4, 8), (8, 10)])
        self.assertEqual([(c.start, c.end) for c in chunks(8, 4)], [(0, 4), (4, 8)])
        self.assertEqual([(c.start, c.end) for c in chunks(3, 5)], [(0, 3)])


class Cli(unittest.TestCase):
    def test_overrides_and_defaults(self):
        args = parser().parse_args(
            ["s.json", "--spp", "8", "--chunk-spp", "2", "-o", "o.exr", "--env-strength", "2"]
        )
        self.assertEqual((args.spp, args.chunk_spp, args.threads_per_task), (8, 2, 1))
        self.assertEqual(args.env_strength, 2.0)
        self.assertIsNone(args.scheduler)
        self.assertEqual(args.light_sampler, "auto")

    def test_the_light_sampler_reaches_every_task(self):
        args = parser().parse_args(
            ["s.json", "--spp", "8", "--chunk-spp", "2", "-o", "o.exr", "--light-sampler", "power"]
        )
        cmd = worker.render_command(
            "lumo", Path("scene.json"), 2, 4, Path("part.npz"), 1, args.light_sampler
        )
        self.assertEqual(cmd[cmd.index("--light-sampler") + 1], "power")
        self.assertEqual(cmd[cmd.index("--samples") + 1], "2..4")

    def test_bad_numbers_exit_2(self):
        for bad in (
            ["--spp", "0"],
            ["--chunk-spp", "-1"],
            ["--retries", "-2"],
            ["--light-sampler", "random"],
        ):
            argv = ["s.json", "--spp", "8", "--chunk-spp", "2", "-o", "o.exr", *bad]
            with self.assertRaises(SystemExit) as caught, open(os.devnull, "w") as null:
                stderr, sys.stderr = sys.stderr, null
                try:
                    parser().parse_args(argv)
                finally:
                    sys.stderr = stderr
            self.assertEqual(caught.exception.code, 2)


class Bundles(unittest.TestCase):
    def zip_with(self, names: dict[str, bytes], link: str | None = None) -> Path:
        path = Path(self.tmp.name) / "b.zip"
        with zipfile.ZipFile(path, "w") as z:
            for name, data in names.items():
                z.writestr(name, data)
            if link:
                info = zipfile.ZipInfo(link)
                info.external_attr = (stat.S_IFLNK | 0o777) << 16
                z.writestr(info, "/etc/passwd")
        return path

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)

    def test_a_bundle_extracts(self):
        path = self.zip_with({"scene.json": b"{}", "files/a/mesh.obj": b"v 0 0 0\n"})
        dest = Path(self.tmp.name) / "x"
        worker.safe_extract(path, dest)
        self.assertEqual((dest / "files/a/mesh.obj").read_bytes(), b"v 0 0 0\n")

    def test_members_outside_the_folder_and_links_are_refused(self):
        dest = Path(self.tmp.name) / "x"
        for name in ("../evil", "/etc/evil", "files/../../evil", "C:/evil", "a\\..\\evil"):
            path = self.zip_with({"scene.json": b"{}", name: b"x"})
            with self.assertRaisesRegex(RuntimeError, "outside its folder"):
                worker.safe_extract(path, dest)
        path = self.zip_with({"scene.json": b"{}"}, link="files/link")
        with self.assertRaisesRegex(RuntimeError, "symbolic link"):
            worker.safe_extract(path, dest)

    def test_the_digest_is_the_files(self):
        path = Path(self.tmp.name) / "f"
        path.write_bytes(b"lumo")
        self.assertEqual(worker.sha256_file(path), "sha256:" + hashlib.sha256(b"lumo").hexdigest())


class Version(unittest.TestCase):
    def test_a_missing_lumo_is_an_error_not_an_exception(self):
        info = worker.lumo_version("/nonexistent/lumo")
        self.assertIn("not found", info["error"])

    def test_a_lumo_that_prints_no_json_is_an_error(self):
        with tempfile.TemporaryDirectory() as tmp:
            fake = Path(tmp) / "lumo"
            fake.write_text("#!/bin/sh\necho hello\n")
            fake.chmod(0o755)
            self.assertIn("no version JSON", worker.lumo_version(str(fake))["error"])
            fake.write_text('#!/bin/sh\necho \'{"version": "9", "build_id": "sha256:00"}\'\n')
            info = worker.lumo_version(str(fake))
            self.assertEqual((info["version"], info["build_id"]), ("9", "sha256:00"))


if __name__ == "__main__":
    unittest.main()
