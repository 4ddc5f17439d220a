//! Shared helpers of the benchmarks: finding `../shared`, loading meshes and `.npy` ray sets,
//! and generating the standard ray sets.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use glam::Vec3;

/// The shared data folder (`$LUMO_SHARED`, else `../shared` beside the workspace root), or
/// `None` after a loud message when it is missing (a panic when `LUMO_REQUIRE_SHARED=1`).
pub fn shared_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("LUMO_SHARED") {
        Some(d) => PathBuf::from(d),
        None => Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join("shared"),
    };
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var("LUMO_REQUIRE_SHARED").as_deref() == Ok("1") {
        panic!(
            "../shared not found at {} and LUMO_REQUIRE_SHARED=1",
            dir.display()
        );
    }
    eprintln!("SKIPPED: ../shared not found (looked at {}; set LUMO_SHARED): benchmarks on the shared meshes are skipped", dir.display());
    None
}

/// A triangle soup: corners of each triangle.
pub struct Soup {
    /// Name for reports.
    pub name: String,
    /// Triangles.
    pub tris: Vec<[Vec3; 3]>,
}

impl Soup {
    /// From indexed positions.
    pub fn indexed(name: &str, positions: &[Vec3], triangles: &[[u32; 3]]) -> Soup {
        Soup {
            name: name.into(),
            tris: triangles
                .iter()
                .map(|t| t.map(|i| positions[i as usize]))
                .collect(),
        }
    }

    /// Centre of the bounding box and the bounding-sphere radius about it (the definition of
    /// `benches/peers/embree_rays.py`).
    pub fn frame(&self) -> (Vec3, Vec3, Vec3, f32) {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for t in &self.tris {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let c = (lo + hi) * 0.5;
        let r = self
            .tris
            .iter()
            .flatten()
            .map(|p| (*p - c).length())
            .fold(0.0f32, f32::max);
        (lo, hi, c, r)
    }
}

/// Loads an OBJ through lumo's one OBJ reader (`lumo_converters::obj`, tobj triangulated).
pub fn load_obj(path: &Path) -> Soup {
    let mesh =
        lumo_converters::obj::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let positions: Vec<Vec3> = mesh.positions.into_iter().map(Vec3::from).collect();
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    Soup::indexed(&name, &positions, &mesh.triangles)
}

/// A ray set.
pub struct Rays {
    /// Origins.
    pub o: Vec<Vec3>,
    /// Directions (unit length).
    pub d: Vec<Vec3>,
}

/// `side²` coherent camera rays: a pinhole at C + (0, 0, 3R) looking down −z through pixel
/// centres, field of view 2·asin(1/3) (the bounding sphere just fits), row-major.
pub fn coherent(soup: &Soup, side: usize) -> Rays {
    let (_, _, c, r) = soup.frame();
    let eye = c + Vec3::new(0.0, 0.0, 3.0 * r);
    let half = (1.0f32 / 3.0).asin().tan();
    let mut rays = Rays {
        o: Vec::with_capacity(side * side),
        d: Vec::with_capacity(side * side),
    };
    for y in 0..side {
        for x in 0..side {
            let sx = ((x as f32 + 0.5) / side as f32 * 2.0 - 1.0) * half;
            let sy = (1.0 - (y as f32 + 0.5) / side as f32 * 2.0) * half;
            rays.o.push(eye);
            rays.d.push(Vec3::new(sx, sy, -1.0).normalize());
        }
    }
    rays
}

/// `n` incoherent rays: origins uniform on the sphere of radius 2R about C, aimed at points
/// uniform in the bounding box (the construction of `embree_rays.py`, with our own generator).
pub fn incoherent(soup: &Soup, n: usize, seed: u64) -> Rays {
    let (lo, hi, c, r) = soup.frame();
    let mut s = seed;
    let mut u = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32) / (1u64 << 24) as f32
    };
    let mut rays = Rays {
        o: Vec::with_capacity(n),
        d: Vec::with_capacity(n),
    };
    for _ in 0..n {
        let z = 1.0 - 2.0 * u();
        let phi = 2.0 * std::f32::consts::PI * u();
        let s = (1.0 - z * z).max(0.0).sqrt();
        let o = c + Vec3::new(s * phi.cos(), s * phi.sin(), z) * (2.0 * r);
        let target = lo + Vec3::new(u(), u(), u()) * (hi - lo);
        rays.o.push(o);
        rays.d.push((target - o).normalize());
    }
    rays
}

/// A parsed `.npy` array (v1.0, little-endian `<f4` or `<i4`, C order).
pub struct Npy {
    /// Shape.
    pub shape: Vec<usize>,
    /// Raw little-endian 4-byte elements.
    pub data: Vec<u8>,
    /// `f4` or `i4`.
    pub kind: String,
}

impl Npy {
    /// Reads a file.
    pub fn read(path: &Path) -> Result<Npy, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
            return Err(format!("{}: not a .npy file", path.display()));
        }
        let (hlen, start) = match bytes[6] {
            1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
            _ => (
                u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
                12,
            ),
        };
        let header = std::str::from_utf8(&bytes[start..start + hlen])
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let kind = if header.contains("'<f4'") {
            "f4"
        } else if header.contains("'<i4'") {
            "i4"
        } else {
            return Err(format!("{}: unsupported dtype in {header}", path.display()));
        };
        if header.contains("'fortran_order': True") {
            return Err(format!("{}: Fortran order unsupported", path.display()));
        }
        let shape_txt = header
            .split("'shape':")
            .nth(1)
            .and_then(|s| s.split(')').next())
            .ok_or(format!("{}: no shape", path.display()))?;
        let shape: Vec<usize> = shape_txt
            .trim_start_matches([' ', '('])
            .split(',')
            .filter_map(|x| x.trim().parse().ok())
            .collect();
        let data = bytes[start + hlen..].to_vec();
        if data.len() != 4 * shape.iter().product::<usize>() {
            return Err(format!(
                "{}: data size does not match shape {shape:?}",
                path.display()
            ));
        }
        Ok(Npy {
            shape,
            data,
            kind: kind.into(),
        })
    }

    /// Elements as f32.
    pub fn f32s(&self) -> Vec<f32> {
        self.data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }

    /// Elements as i32.
    pub fn i32s(&self) -> Vec<i32> {
        self.data
            .chunks_exact(4)
            .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }

    /// Rows of three as vectors.
    pub fn vec3s(&self) -> Vec<Vec3> {
        self.f32s()
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect()
    }
}

/// One saved ray set: its kind, the rays, and Embree's closest-hit triangle per ray (−1: miss).
pub type RaySet = (String, Rays, Vec<i32>);

/// The ray sets saved by `benches/peers/embree_rays.py` for `mesh`, when `$LUMO_RAYS_DIR` is
/// set: the mesh, and per kind the rays with Embree's closest-hit triangle per ray (−1: miss).
pub fn embree_rays(mesh: &str) -> Option<(Soup, Vec<RaySet>)> {
    let dir = PathBuf::from(std::env::var_os("LUMO_RAYS_DIR")?);
    let load = || -> Result<(Soup, Vec<RaySet>), String> {
        let v = Npy::read(&dir.join(format!("{mesh}_vertices.npy")))?.vec3s();
        let f = Npy::read(&dir.join(format!("{mesh}_indices.npy")))?.i32s();
        let idx: Vec<[u32; 3]> = f
            .chunks_exact(3)
            .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32])
            .collect();
        let soup = Soup::indexed(mesh, &v, &idx);
        let mut sets = Vec::new();
        for kind in ["coherent", "incoherent"] {
            let o = Npy::read(&dir.join(format!("{mesh}_{kind}_origins.npy")))?.vec3s();
            let d = Npy::read(&dir.join(format!("{mesh}_{kind}_dirs.npy")))?.vec3s();
            let prim = Npy::read(&dir.join(format!("{mesh}_{kind}_embree_prim.npy")))?.i32s();
            sets.push((kind.to_string(), Rays { o, d }, prim));
        }
        Ok((soup, sets))
    };
    match load() {
        Ok(x) => Some(x),
        Err(e) => {
            eprintln!("SKIPPED: Embree ray sets for {mesh} in $LUMO_RAYS_DIR: {e}");
            None
        }
    }
}
