//! Triangle meshes of lathes (for exporters, previews and the exact-vs-mesh image check).

use super::Lathe;
use glam::{DVec2, DVec3};
use std::f64::consts::TAU;

/// An indexed triangle mesh with per-vertex normals and texture coordinates.
#[derive(Debug, Clone, Default)]
pub struct Tessellation {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Unit vertex normals (the lathe's orientation rule).
    pub normals: Vec<DVec3>,
    /// Vertex texture coordinates (u = θ/2π, v = profile parameter).
    pub uvs: Vec<DVec2>,
    /// Counter-clockwise triangles (front = the lathe's outside).
    pub indices: Vec<[u32; 3]>,
}

impl Lathe {
    /// Tessellates the lathe with `angular_segments` (≥ 3) steps around the axis and
    /// `profile_samples` (≥ 2) points along the profile, uniform in θ and v.
    ///
    /// Vertex order follows three.js `LatheGeometry`: for each angle step i = 0..=segments
    /// (the seam is duplicated so u runs 0 → 1), the profile points j = 0..samples;
    /// vertex (i, j) has index i·samples + j and uv (i/segments, j/(samples−1)). The angle
    /// convention is this crate's, S(t, θ) = (x cos θ, y, −x sin θ). Triangles (a, b, d) and
    /// (c, d, b) with a = (i, j), b = (i+1, j), c = (i+1, j+1), d = (i, j+1) face along
    /// ∂S/∂θ × ∂S/∂t, the lathe's front.
    pub fn tessellate(&self, angular_segments: usize, profile_samples: usize) -> Tessellation {
        let segs = angular_segments.max(3);
        let samples = profile_samples.max(2);
        let mut profile: Vec<(DVec2, ProfileNormal)> = Vec::with_capacity(samples);
        for j in 0..samples {
            let v = j as f64 / (samples - 1) as f64;
            profile.push((self.profile.eval(v).0, self.profile_normal(v)));
        }
        let mut out = Tessellation::default();
        for i in 0..=segs {
            let u = i as f64 / segs as f64;
            let (sin, cos) = (u * TAU).sin_cos();
            for (j, (p, n)) in profile.iter().enumerate() {
                out.positions.push(DVec3::new(p.x * cos, p.y, -p.x * sin));
                out.normals.push(n.at(cos, sin));
                out.uvs.push(DVec2::new(u, j as f64 / (samples - 1) as f64));
            }
        }
        let s = samples as u32;
        for i in 0..segs as u32 {
            for j in 0..s - 1 {
                let a = i * s + j;
                let b = a + s;
                let c = b + 1;
                let d = a + 1;
                out.indices.push([a, b, d]);
                out.indices.push([c, d, b]);
            }
        }
        out
    }

    /// The normal of the profile at v, as radial and axial components.
    fn profile_normal(&self, v: f64) -> ProfileNormal {
        let (p, dp) = self.profile.eval(v);
        let scale = self.scale;
        if p.x.abs() > 1e-12 * scale {
            // n = x·(y′ cos θ, −x′, −y′ sin θ), normalised.
            let n = p.x.signum() * DVec2::new(dp.y, -dp.x);
            let len = n.length();
            if len > 0.0 {
                return ProfileNormal {
                    radial: n.x / len,
                    axial: n.y / len,
                };
            }
        }
        // Pole (or a vanishing derivative): take the side the curve lies on just inside.
        let vn = if v < 0.5 { v + 1e-6 } else { v - 1e-6 };
        let (pn, dpn) = self.profile.eval(vn);
        let axial = if dp.x != 0.0 {
            -(pn.x * dp.x).signum()
        } else {
            -(pn.x * dpn.x).signum()
        };
        if p.x.abs() <= 1e-12 * scale {
            return ProfileNormal { radial: 0.0, axial };
        }
        let n = pn.x.signum() * DVec2::new(dpn.y, -dpn.x);
        let n = n.normalize_or(DVec2::new(0.0, axial));
        ProfileNormal {
            radial: n.x,
            axial: n.y,
        }
    }
}

/// A normal as (radial, axial) components, to be rotated to an angle.
#[derive(Debug, Clone, Copy)]
struct ProfileNormal {
    radial: f64,
    axial: f64,
}

impl ProfileNormal {
    fn at(&self, cos: f64, sin: f64) -> DVec3 {
        DVec3::new(self.radial * cos, self.axial, -self.radial * sin)
    }
}
