//! Partial films end to end through the `lumo` binary: any split of a render's samples (sample
//! ranges, crop windows, thread counts), merged in any order or grouping, gives the bytes of one
//! uninterrupted render; bad films are refused with exit code 2 and a message naming the file and
//! the problem; bundles keep the scene's hash.

mod common;

use std::path::{Path, PathBuf};

use assert_cmd::Command;

/// A small, fast render of the Cornell box (diffuse, glass and a lathe: long paths, many
/// samples dropped by roulette at different depths).
const SIZE: [&str; 4] = ["--width", "40", "--height", "30"];
const SPP: u32 = 21;

fn lumo() -> Command {
    Command::cargo_bin("lumo").expect("the lumo binary")
}

fn scene() -> PathBuf {
    common::root().join("scenes/cornell.json")
}

/// Runs `lumo` with these arguments; panics with its stderr unless it exits with 0.
fn ok(args: &[&str]) {
    let out = lumo().args(args).output().expect("lumo runs");
    assert!(
        out.status.success(),
        "lumo {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs `lumo`, expecting exit code 2; returns its stderr.
fn refused(args: &[&str]) -> String {
    let out = lumo().args(args).output().expect("lumo runs");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "lumo {args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

fn p(path: &Path) -> &str {
    path.to_str().expect("utf-8 temp path")
}

/// Renders sample range a..b (and optionally a window) to a partial film.
fn part(dir: &Path, name: &str, a: u32, b: u32, extra: &[&str]) -> PathBuf {
    let film = dir.join(format!("{name}.npz"));
    let samples = format!("{a}..{b}");
    let scene = scene();
    let mut args = vec![
        "render",
        p(&scene),
        "--samples",
        &samples,
        "--film",
        p(&film),
        "-q",
    ];
    args.extend(SIZE);
    args.extend(extra);
    ok(&args);
    film
}

/// The EXR of one uninterrupted render of `spp` samples.
fn full_render(dir: &Path, spp: u32, threads: &str) -> Vec<u8> {
    let out = dir.join(format!("full_{spp}_{threads}.exr"));
    let spp = spp.to_string();
    let scene = scene();
    let mut args = vec![
        "render",
        p(&scene),
        "--spp",
        &spp,
        "-o",
        p(&out),
        "-q",
        "--threads",
        threads,
    ];
    args.extend(SIZE);
    ok(&args);
    std::fs::read(&out).expect("the render")
}

fn merged(dir: &Path, name: &str, parts: &[&PathBuf]) -> Vec<u8> {
    let out = dir.join(format!("{name}.exr"));
    let mut args = vec!["merge"];
    args.extend(parts.iter().map(|f| p(f)));
    args.extend(["-o", p(&out)]);
    ok(&args);
    std::fs::read(&out).expect("the merge")
}

/// Boundaries of an n-way split of 0..SPP, uneven on purpose.
fn split(n: u32) -> Vec<(u32, u32)> {
    let mut cuts: Vec<u32> = (0..=n).map(|k| (k * k * SPP).div_ceil(n * n)).collect();
    cuts.dedup();
    cuts.windows(2).map(|w| (w[0], w[1])).collect()
}

#[test]
fn any_split_merged_in_any_order_is_bit_identical_to_one_render() {
    let dir = tempfile::tempdir().expect("temp dir");
    let reference = full_render(dir.path(), SPP, "2");
    assert_eq!(
        full_render(dir.path(), SPP, "1"),
        reference,
        "one thread and two differ"
    );
    for n in [1, 2, 3, 7] {
        let ranges = split(n);
        assert_eq!(ranges.len() as u32, n, "{ranges:?}");
        let films: Vec<PathBuf> = ranges
            .iter()
            .enumerate()
            .map(|(i, &(a, b))| {
                // Alternate thread counts: the film must not depend on them.
                let threads = if i % 2 == 0 { "1" } else { "2" };
                part(
                    dir.path(),
                    &format!("s{n}_{i}"),
                    a,
                    b,
                    &["--threads", threads],
                )
            })
            .collect();
        let forward: Vec<&PathBuf> = films.iter().collect();
        assert_eq!(
            merged(dir.path(), &format!("m{n}"), &forward),
            reference,
            "{n}-way split"
        );
        // Shuffled: reversed, and every other one first.
        let mut shuffled: Vec<&PathBuf> = films.iter().rev().collect();
        shuffled.sort_by_key(|f| f.to_string_lossy().len() % 2);
        assert_eq!(
            merged(dir.path(), &format!("m{n}_shuffled"), &shuffled),
            reference,
            "{n}-way split, shuffled"
        );
    }
    // Nested: merge the 7 parts in groups into bigger films, then merge those.
    let films: Vec<PathBuf> = (0..7)
        .map(|i| dir.path().join(format!("s7_{i}.npz")))
        .collect();
    let group_a = dir.path().join("group_a.npz");
    let group_b = dir.path().join("group_b.npz");
    ok(&[
        "merge",
        p(&films[5]),
        p(&films[0]),
        p(&films[3]),
        "--film",
        p(&group_a),
    ]);
    ok(&[
        "merge",
        p(&films[1]),
        p(&films[6]),
        p(&films[2]),
        p(&films[4]),
        "--film",
        p(&group_b),
    ]);
    assert_eq!(
        merged(dir.path(), "nested", &[&group_b, &group_a]),
        reference
    );
}

#[test]
fn crop_windows_and_sample_ranges_merge_into_the_full_render() {
    let dir = tempfile::tempdir().expect("temp dir");
    let reference = full_render(dir.path(), SPP, "2");
    // Four windows (left column split at row 11; right column whole), the right one in two
    // sample ranges.
    let a = part(dir.path(), "a", 0, SPP, &["--crop", "0,0,17,11"]);
    let b = part(dir.path(), "b", 0, SPP, &["--crop", "0,11,17,30"]);
    let c1 = part(
        dir.path(),
        "c1",
        0,
        9,
        &["--crop", "17,0,40,30", "--threads", "1"],
    );
    let c2 = part(dir.path(), "c2", 9, SPP, &["--crop", "17,0,40,30"]);
    assert_eq!(
        merged(dir.path(), "windows", &[&c2, &a, &c1, &b]),
        reference
    );
    // A missing window is a gap: refused, unless allowed.
    let err = refused(&[
        "merge",
        p(&a),
        p(&c1),
        p(&c2),
        "-o",
        p(&dir.path().join("x.exr")),
    ]);
    assert!(
        err.contains("no samples") && err.contains("--allow-partial"),
        "{err}"
    );
    ok(&[
        "merge",
        p(&a),
        p(&c1),
        p(&c2),
        "--allow-partial",
        "-o",
        p(&dir.path().join("x.exr")),
    ]);
    // Missing sample indices are a gap too.
    let late = part(dir.path(), "late", 15, SPP, &["--crop", "0,0,17,11"]);
    let first = part(dir.path(), "first", 0, 9, &["--crop", "0,0,17,11"]);
    let err = refused(&[
        "merge",
        p(&first),
        p(&late),
        "-o",
        p(&dir.path().join("y.exr")),
    ]);
    assert!(err.contains("samples 9..15 are missing"), "{err}");
}

/// Writes `bytes` as a file in `dir` and returns its path.
fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).expect("write");
    path
}

#[test]
fn bad_partial_films_are_refused_with_the_file_and_the_reason() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let good = part(d, "good", 0, 4, &[]);
    let next = part(d, "next", 4, 8, &[]);
    let bytes = std::fs::read(&good).expect("film");
    let out = d.join("out.exr");
    let merge = |films: &[&Path]| {
        let mut args = vec!["merge"];
        args.extend(films.iter().map(|f| p(f)));
        args.extend(["-o", p(&out)]);
        refused(&args)
    };

    // Truncated at several lengths.
    for cut in [0, 10, bytes.len() / 3, bytes.len() - 1] {
        let t = write(d, &format!("cut{cut}.npz"), &bytes[..cut]);
        let err = merge(&[&good, &t]);
        assert!(
            err.contains(p(&t)) && err.contains("partial film"),
            "cut {cut}: {err}"
        );
    }
    // Bit flips anywhere: the zip's checksums or the checks of the contents catch every one.
    for k in 0..24 {
        let mut flipped = bytes.clone();
        let at = (k * 7919 + 13) % flipped.len();
        flipped[at] ^= 1 << (k % 8);
        let f = write(d, &format!("flip{k}.npz"), &flipped);
        let err = merge(&[&f, &next]);
        assert!(err.contains(p(&f)), "flip at {at}: {err}");
    }
    // Another scene, seed, resolution; overlapping ranges.
    let scene = scene();
    let other_scene_film = d.join("other_scene.npz");
    let glass = common::root().join("scenes/cornell_glass.json");
    let mut args = vec![
        "render",
        p(&glass),
        "--samples",
        "4..8",
        "--film",
        p(&other_scene_film),
        "-q",
    ];
    args.extend(SIZE);
    ok(&args);
    let err = merge(&[&good, &other_scene_film]);
    assert!(err.contains("the scene differs"), "{err}");
    // What a user changed on the command line is named, though the scene's hash covers it too.
    let seeded = part(d, "seeded", 4, 8, &["--seed", "99"]);
    let err = merge(&[&good, &seeded]);
    assert!(err.contains("the seed differs"), "{err}");
    // The Cornell box picks its light by power; the same samples with the light tree are other
    // samples.
    let treed = part(d, "treed", 4, 8, &["--light-sampler", "tree"]);
    let err = merge(&[&good, &treed]);
    assert!(
        err.contains("the sampler") && err.contains("light tree"),
        "{err}"
    );
    let bigger = d.join("bigger.npz");
    ok(&[
        "render",
        p(&scene),
        "--samples",
        "4..8",
        "--film",
        p(&bigger),
        "-q",
        "--width",
        "41",
        "--height",
        "30",
    ]);
    let err = merge(&[&good, &bigger]);
    assert!(err.contains("the resolution differs"), "{err}");
    let overlap = part(d, "overlap", 2, 6, &[]);
    let err = merge(&[&good, &overlap]);
    assert!(
        err.contains("overlap") && err.contains("0..4") && err.contains("2..6"),
        "{err}"
    );
    // Not a film at all, and a resume from a film of another scene.
    let text = write(d, "text.npz", b"hello");
    assert!(merge(&[&text]).contains("not a readable .npz"));
    let err = refused(&[
        "render",
        p(&glass),
        "--width",
        "40",
        "--height",
        "30",
        "--spp",
        "8",
        "-o",
        p(&out),
        "--resume",
        p(&good),
    ]);
    assert!(
        err.contains("cannot resume") && err.contains("scene"),
        "{err}"
    );
}

#[test]
fn problems_are_found_before_rendering() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = scene();
    let missing = dir.path().join("no_such_folder/x.png");
    let err = refused(&["render", p(&scene), "--spp", "100000", "-o", p(&missing)]);
    assert!(err.contains("does not exist"), "{err}");
    let err = refused(&[
        "render",
        p(&scene),
        "--samples",
        "0..4",
        "--film",
        p(&dir.path().join("f.exr")),
    ]);
    assert!(err.contains(".npz"), "{err}");
    for flag in [
        &["--adaptive"][..],
        &["--target-error", "0.1"],
        &["--time", "1s"],
    ] {
        let mut args = vec!["render", p(&scene), "--samples", "0..4", "--film"];
        let f = dir.path().join("f.npz");
        args.push(p(&f));
        args.extend(flag);
        let err = refused(&args);
        assert!(err.contains("cannot be split"), "{flag:?}: {err}");
    }
}

#[test]
fn a_bundle_renders_films_that_merge_with_the_original_scene() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    // A scene with a texture in another folder (scenes/textures/).
    let scene = common::root().join("scenes/lathe_vase.json");
    let bundle = d.join("b.zip");
    let out = lumo()
        .args([
            "bundle",
            p(&scene),
            "--width",
            "24",
            "--height",
            "18",
            "-o",
            p(&bundle),
        ])
        .output()
        .expect("lumo runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let printed: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("bundle prints JSON");
    let hash = printed["scene_hash"]
        .as_str()
        .expect("scene_hash")
        .to_string();
    let unpacked = d.join("unpacked");
    let mut zip =
        zip::ZipArchive::new(std::fs::File::open(&bundle).expect("bundle")).expect("a zip");
    zip.extract(&unpacked).expect("extract");
    let from_bundle = d.join("from_bundle.npz");
    let bundled_scene = unpacked.join("scene.json");
    ok(&[
        "render",
        p(&bundled_scene),
        "--samples",
        "0..3",
        "--film",
        p(&from_bundle),
        "-q",
    ]);
    let from_original = d.join("from_original.npz");
    ok(&[
        "render",
        p(&scene),
        "--width",
        "24",
        "--height",
        "18",
        "--samples",
        "3..6",
        "--film",
        p(&from_original),
        "-q",
    ]);
    let film = lumo::partial_film::PartialFilm::read(&from_bundle).expect("film");
    assert_eq!(film.header.scene_hash, hash);
    let reference = d.join("ref.exr");
    ok(&[
        "render",
        p(&scene),
        "--width",
        "24",
        "--height",
        "18",
        "--spp",
        "6",
        "-o",
        p(&reference),
        "-q",
    ]);
    assert_eq!(
        merged(d, "bundle_merge", &[&from_original, &from_bundle]),
        std::fs::read(&reference).expect("ref")
    );
}

#[test]
fn an_output_that_cannot_be_written_at_the_end_keeps_the_samples() {
    let dir = tempfile::tempdir().expect("temp dir");
    // A folder where the image should go: every check before rendering passes (the folder it
    // is in exists and is writable), the final rename fails.
    let blocked = dir.path().join("frame.exr");
    std::fs::create_dir(&blocked).expect("folder");
    let scene = scene();
    let mut args = vec!["render", p(&scene), "--spp", "5", "-q", "-o", p(&blocked)];
    args.extend(SIZE);
    let out = lumo().args(&args).output().expect("lumo runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let kept = dir.path().join("frame.exr.checkpoint.npz");
    assert!(
        err.contains("the samples are kept in") && err.contains(p(&kept)),
        "{err}"
    );
    // The checkpoint merges into the image the render would have written.
    let merged_image = dir.path().join("merged.exr");
    ok(&["merge", p(&kept), "-o", p(&merged_image)]);
    let reference = full_render(dir.path(), 5, "2");
    assert_eq!(std::fs::read(&merged_image).expect("merged"), reference);
}
