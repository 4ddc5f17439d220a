//! Triangle meshes in object space, each with its own BVH, shared between instances.

use std::sync::{Arc, OnceLock};

use glam::{Vec3A, Vec4};
use rayon::prelude::*;

use crate::geometry::triangle_bvh::{prefetch_line, TriRay, TriangleBvh};
use crate::geometry::triangle_source::{SourcePart, TriangleSource};
use crate::geometry::RawHit;
use crate::lanes::{F32s, Mask, V3s};
use crate::math::{Aabb, Affine3A, Mat3, Vec2, Vec3};

/// A mesh's vertex and triangle arrays, as a loader reads them and as a [`Mesh`] keeps them. The
/// arrays are shared (`Arc`), so a mesh read from a file is in memory once whatever uses it.
#[derive(Debug, Clone, Default)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Arc<Vec<Vec3>>,
    /// Triangles (counter-clockwise front), indices into `positions`.
    pub triangles: Arc<Vec<[u32; 3]>>,
    /// Unit vertex normals for smooth shading, when present.
    pub normals: Option<Arc<Vec<Vec3>>>,
    /// Vertex texture coordinates, when present.
    pub uvs: Option<Arc<Vec<Vec2>>>,
    /// The second set of vertex texture coordinates (glTF `TEXCOORD_1`), when present.
    pub uvs1: Option<Arc<Vec<Vec2>>>,
    /// Vertex tangents (xyz) and bitangent handedness (w = ±1, glTF `TANGENT`), when present.
    pub tangents: Option<Arc<Vec<Vec4>>>,
    /// Linear RGBA vertex colours (glTF `COLOR_0`), when present.
    pub colors: Option<Arc<Vec<Vec4>>>,
}

/// An indexed triangle mesh with optional per-vertex attributes, its bounds and its BVH.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// The arrays.
    pub data: MeshData,
    bounds: Aabb,
    /// Built on first use: a mesh whose only instances are flattened into the scene's
    /// world-space triangle set never needs its own.
    bvh: OnceLock<TriangleBvh>,
}

/// What a material's opacity reads at a hit (see [`crate::material::Material::opacity`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpacityInputs {
    /// Texture coordinates (set 0).
    pub uv: Vec2,
    /// Texture coordinates (set 1).
    pub uv1: Vec2,
    /// The vertex colour's alpha (1 without vertex colours).
    pub color_alpha: f32,
}

/// Per-vertex `values` at a hit on triangle `tri`: b0·v₀ + b1·v₁ + b2·v₂ with b0 = 1 − b1 − b2
/// and (b1, b2) those of `h`, in this order (so that every attribute, wherever it is read, has
/// the same bits).
#[inline(always)]
fn interpolate<T>(values: &[T], tri: [u32; 3], b0: f32, h: &MeshHit) -> T
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    values[tri[0] as usize] * b0 + values[tri[1] as usize] * h.b1 + values[tri[2] as usize] * h.b2
}

/// Where a ray meets a mesh.
#[derive(Debug, Clone, Copy)]
pub struct MeshHit {
    /// Ray parameter.
    pub t: f32,
    /// Triangle index.
    pub prim: u32,
    /// Barycentric weight of the triangle's second vertex.
    pub b1: f32,
    /// Barycentric weight of the triangle's third vertex.
    pub b2: f32,
}

impl MeshHit {
    /// The mesh hit a [`RawHit`] on a mesh records.
    #[inline]
    pub fn of_raw(raw: &RawHit) -> MeshHit {
        MeshHit {
            t: raw.t,
            prim: raw.prim,
            b1: raw.coords[0],
            b2: raw.coords[1],
        }
    }
}

/// Triangles per task of [`Mesh::new`]'s pass over the triangles.
const BOUNDS_CHUNK: usize = 16 * 1024;
/// How many triangles ahead that pass asks for corners.
const PREFETCH_AHEAD: usize = 16;

impl Mesh {
    /// Makes a mesh (its BVH is built on first use, see [`Mesh::bvh`]). Degenerate (zero-area)
    /// triangles are removed; the number removed is returned alongside so the loader can warn
    /// once. A second texture set, tangents or colours without one entry per vertex are
    /// dropped (the loaders check lengths).
    pub fn new(mut data: MeshData) -> (Mesh, usize) {
        let n = data.positions.len();
        data.uvs1 = data.uvs1.filter(|a| a.len() == n);
        data.tangents = data.tangents.filter(|a| a.len() == n);
        data.colors = data.colors.filter(|a| a.len() == n);
        let positions = &data.positions;
        let corners = |t: &[u32; 3]| t.map(|i| Vec3A::from(positions[i as usize]));
        let area = |[a, b, c]: [Vec3A; 3]| crate::math::cross(b - a, c - a).length_squared() > 0.0;
        // In SIMD registers (`Vec3A`: each `min` and `max` one instruction, against a compare
        // and blend per component for `Vec3`'s form, with the same result: `x < y ? x : y`, and a
        // cross product of the same products), over chunks of triangles in their order, each
        // corner's position (scattered: vertices are shared with neighbours numbered anywhere)
        // asked for a few triangles ahead, as the BVH's box pass does.
        let bounds_of = |tris: &[[u32; 3]]| {
            let (min, max, all_ok) = tris
                .par_chunks(BOUNDS_CHUNK)
                .map(|chunk| {
                    let (mut min, mut max, mut ok) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY, true);
                    for (k, t) in chunk.iter().enumerate() {
                        if let Some(ahead) = chunk.get(k + PREFETCH_AHEAD) {
                            for &i in ahead {
                                prefetch_line(positions.as_ptr().wrapping_add(i as usize));
                            }
                        }
                        let t = corners(t);
                        for c in t {
                            (min, max) = (min.min(c), max.max(c));
                        }
                        ok &= area(t);
                    }
                    (min, max, ok)
                })
                .reduce(
                    || (Vec3A::INFINITY, Vec3A::NEG_INFINITY, true),
                    |a, b| (a.0.min(b.0), a.1.max(b.1), a.2 && b.2),
                );
            let bounds = Aabb {
                min: min.into(),
                max: max.into(),
            };
            (bounds, all_ok)
        };
        let before = data.triangles.len();
        let (mut bounds, all_ok) = bounds_of(&data.triangles);
        // Copied only when some triangle is dropped; else shared with the caller.
        if !all_ok {
            let kept = |t: &[u32; 3]| area(corners(t));
            data.triangles = Arc::new(data.triangles.par_iter().copied().filter(kept).collect());
            bounds = bounds_of(&data.triangles).0;
        }
        let dropped = before - data.triangles.len();
        (
            Mesh {
                data,
                bounds,
                bvh: OnceLock::new(),
            },
            dropped,
        )
    }

    /// A mesh of positions and triangles alone ([`Mesh::new`]).
    pub fn from_triangles(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> (Mesh, usize) {
        Mesh::new(MeshData {
            positions: Arc::new(positions),
            triangles: Arc::new(triangles),
            ..MeshData::default()
        })
    }

    /// Bounds in object space.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The mesh's own BVH (object space), built on first call.
    pub fn bvh(&self) -> &TriangleBvh {
        self.bvh.get_or_init(|| {
            let source = TriangleSource::new(vec![self.triangle_source_part(0, 0, None)]);
            TriangleBvh::from_source(self.data.triangles.len(), source, |p| p as u32)
        })
    }

    /// This mesh's triangles as part of a [`TriangleSource`]: its first triangle numbered
    /// `first`, its ids tagged `tag`, placed by `to_world` (none: the identity). The mesh's own
    /// tree reads the part `(0, 0, None)`, whose corners are [`Mesh::corners`].
    pub fn triangle_source_part(
        &self,
        first: u32,
        tag: u32,
        to_world: Option<Affine3A>,
    ) -> SourcePart {
        SourcePart {
            first,
            tag,
            positions: Arc::clone(&self.data.positions),
            triangles: Arc::clone(&self.data.triangles),
            to_world,
        }
    }

    /// The three corners of triangle `prim`.
    #[inline]
    pub fn corners(&self, prim: u32) -> [Vec3; 3] {
        self.data.triangles[prim as usize].map(|i| self.data.positions[i as usize])
    }

    /// Closest hit within (t_min, t_max).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<MeshHit> {
        self.bvh()
            .intersect(&TriRay::new(o, d), t_min, t_max)
            .map(|(id, h)| MeshHit {
                t: h.t,
                prim: id[1],
                b1: h.b1,
                b2: h.b2,
            })
    }

    /// Whether anything is hit within (t_min, t_max).
    pub fn occluded(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        self.bvh().occluded(&TriRay::new(o, d), t_min, t_max)
    }

    /// [`Mesh::intersect`] keeping only the hits `accept` takes (see
    /// [`TriangleBvh::intersect_accepted`]), as [`RawHit`]s.
    pub fn intersect_accepted(
        &self,
        o: Vec3,
        d: Vec3,
        t_min: f32,
        t_max: f32,
        accept: &mut dyn FnMut(&RawHit) -> bool,
    ) -> Option<RawHit> {
        self.bvh()
            .intersect_accepted(&TriRay::new(o, d), t_min, t_max, &mut |id, h| {
                accept(&RawHit::of_triangle(id, h))
            })
            .map(|(id, h)| RawHit::of_triangle(id, &h))
    }

    /// Whether a hit within (t_min, t_max) is one `accept` takes.
    pub fn occluded_accepted(
        &self,
        o: Vec3,
        d: Vec3,
        t_min: f32,
        t_max: f32,
        accept: &mut dyn FnMut(&RawHit) -> bool,
    ) -> bool {
        self.bvh()
            .occluded_accepted(&TriRay::new(o, d), t_min, t_max, &mut |id, h| {
                accept(&RawHit::of_triangle(id, h))
            })
    }

    /// Whether the mesh has nothing but positions (no normals, texture coordinates or other
    /// attributes): a hit's surface inputs are then its triangle's corners alone.
    #[inline]
    pub fn has_positions_only(&self) -> bool {
        !self.has_attributes() && self.data.normals.is_none() && self.data.uvs.is_none()
    }

    /// Whether the mesh has any of the attributes [`Mesh::attributes`] interpolates.
    #[inline]
    pub fn has_attributes(&self) -> bool {
        self.data.uvs1.is_some() || self.data.tangents.is_some() || self.data.colors.is_some()
    }

    /// The vertex attributes of a hit beyond [`Mesh::surface`]'s: second texture coordinates,
    /// tangent (xyz, object space, not normalised; w = handedness) and colour, interpolated;
    /// defaults (0, zero tangent, white) where the mesh has none.
    pub fn attributes(&self, h: &MeshHit) -> (Vec2, Vec4, Vec4) {
        let tri = self.data.triangles[h.prim as usize];
        let b0 = 1.0 - h.b1 - h.b2;
        let lerp = |a: &Arc<Vec<_>>| interpolate(a, tri, b0, h);
        let uv1 = self.data.uvs1.as_ref().map_or(Vec2::ZERO, lerp);
        let tangent = self.data.tangents.as_ref().map_or(Vec4::ZERO, |t| {
            // The handedness is per vertex; take the first corner's rather than a blend.
            interpolate(t, tri, b0, h)
                .truncate()
                .extend(t[tri[0] as usize].w.signum())
        });
        let color = self
            .data
            .colors
            .as_ref()
            .map_or(Vec4::ONE, |c| interpolate(c, tri, b0, h));
        (uv1, tangent, color)
    }

    /// Interpolated point, geometric normal, shading normal and texture coordinates of a hit.
    pub fn surface(&self, h: &MeshHit) -> (Vec3, Vec3, Vec3, Vec2) {
        let tri = self.data.triangles[h.prim as usize];
        let [a, b, c] = tri.map(|i| self.data.positions[i as usize]);
        let b0 = 1.0 - h.b1 - h.b2;
        let p = a * b0 + b * h.b1 + c * h.b2;
        let ng = (b - a).cross(c - a).normalize();
        let ns = match &self.data.normals {
            Some(n) => {
                let s = interpolate(n, tri, b0, h).normalize_or_zero();
                if s == Vec3::ZERO {
                    ng
                } else {
                    s
                }
            }
            None => ng,
        };
        (p, ng, ns, self.uv(tri, b0, h))
    }

    /// Puts lane `i` of `lanes` to the hit `h` on this mesh, for [`SurfaceLanes::run`]: its
    /// triangle's corners, and its vertex normals and texture coordinates where the mesh has
    /// them.
    #[inline]
    pub fn gather_surface<const W: usize>(
        &self,
        lanes: &mut SurfaceLanes<W>,
        i: usize,
        h: &MeshHit,
    ) {
        lanes.set_corners(i, &self.corner_data(h.prim), (h.b1, h.b2));
    }

    /// What [`gather_surface`](Self::gather_surface) reads of triangle `prim`: its corners,
    /// and their vertex normals and texture coordinates where the mesh has them.
    pub fn corner_data(&self, prim: u32) -> CornerData {
        let tri = self.data.triangles[prim as usize];
        let p = &self.data.positions;
        CornerData {
            positions: tri.map(|v| p[v as usize]),
            normals: self
                .data
                .normals
                .as_ref()
                .map(|n| tri.map(|v| n[v as usize])),
            uvs: self.data.uvs.as_ref().map(|uv| tri.map(|v| uv[v as usize])),
        }
    }

    /// Interpolated texture coordinates of a hit on triangle `tri` (barycentric weights b0 and
    /// those of `h`); the barycentric coordinates themselves without them.
    #[inline(always)]
    fn uv(&self, tri: [u32; 3], b0: f32, h: &MeshHit) -> Vec2 {
        match &self.data.uvs {
            Some(t) => interpolate(t, tri, b0, h),
            None => Vec2::new(h.b1, h.b2),
        }
    }

    /// What alpha masks and blending read at a hit, as [`Mesh::surface`] and
    /// [`Mesh::attributes`] compute it: both texture coordinate sets and the vertex colour's
    /// alpha (1 without colours), and nothing else of the surface.
    pub fn opacity_inputs(&self, h: &MeshHit) -> OpacityInputs {
        let tri = self.data.triangles[h.prim as usize];
        let b0 = 1.0 - h.b1 - h.b2;
        let uv1 = self
            .data
            .uvs1
            .as_ref()
            .map_or(Vec2::ZERO, |a| interpolate(a, tri, b0, h));
        let color_alpha = self
            .data
            .colors
            .as_ref()
            .map_or(1.0, |c| interpolate(c, tri, b0, h).w);
        OpacityInputs {
            uv: self.uv(tri, b0, h),
            uv1,
            color_alpha,
        }
    }

    /// Angle-weighted vertex normals (Thürmer and Wüthrich 1998): each face contributes its
    /// normal weighted by its corner angle at the vertex, so the result does not depend on how
    /// a surface is split into triangles.
    pub fn angle_weighted_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
        lumo_schema::geometry::normals::angle_weighted_normals(positions, triangles)
    }
}

/// A unit icosphere: the regular icosahedron with every triangle split into four
/// `subdivisions` times, new vertices pushed onto the sphere; 20·4ⁿ triangles (n = 7 gives
/// 327,680, n = 8 gives 1,310,720), counter-clockwise seen from outside. Used by tests,
/// benchmarks and generated scene assets.
pub fn icosphere(subdivisions: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let g = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid = std::collections::HashMap::with_capacity(tris.len() * 3 / 2);
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                positions.len() as u32 - 1
            })
        };
        for &[a, b, c] in &tris {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    (positions, tris)
}

/// A triangle's corners as [`SurfaceLanes`] reads them: positions, and vertex normals and
/// texture coordinates where its mesh has them (object space).
#[derive(Debug, Clone, Copy)]
pub struct CornerData {
    /// The corners' positions.
    pub positions: [Vec3; 3],
    /// Their vertex normals.
    pub normals: Option<[Vec3; 3]>,
    /// Their texture coordinates.
    pub uvs: Option<[Vec2; 3]>,
}

/// W hits on meshes, one per lane, for [`Mesh::surface`] in SIMD lanes (lanes set by
/// [`Mesh::gather_surface`]; the others hold whatever they held, and their results mean
/// nothing).
#[repr(C, align(64))]
pub struct SurfaceLanes<const W: usize> {
    corners: [V3s<W>; 3],
    b1: F32s<W>,
    b2: F32s<W>,
    /// The lanes whose mesh has vertex normals, and those normals at the corners.
    smooth: Mask<W>,
    normals: [V3s<W>; 3],
    /// The lanes whose mesh has texture coordinates, and those at the corners.
    textured: Mask<W>,
    uvs: [(F32s<W>, F32s<W>); 3],
    /// The lanes whose instance is placed by a transform, its object → world map (the columns
    /// of the linear part, then the translation) and its normal map's columns.
    transformed: Mask<W>,
    to_world: [V3s<W>; 4],
    normal_to_world: [V3s<W>; 3],
    /// The lanes whose geometric and shading normals are given (a flat triangle's, computed
    /// once, with these operations), and those normals.
    given: Mask<W>,
    given_normal: V3s<W>,
}

/// What [`SurfaceLanes::run`] computes in each lane: [`Mesh::surface`]'s point, geometric
/// and shading normals and texture coordinates.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
pub struct SurfacesOut<const W: usize> {
    /// The hit point.
    pub p: V3s<W>,
    /// The unit geometric normal.
    pub ng: V3s<W>,
    /// The unit shading normal.
    pub ns: V3s<W>,
    /// The texture coordinates.
    pub uv: (F32s<W>, F32s<W>),
}

impl<const W: usize> Default for SurfaceLanes<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> SurfaceLanes<W> {
    /// Lanes of nothing (zeros).
    pub fn new() -> Self {
        SurfaceLanes {
            corners: [V3s::default(); 3],
            b1: F32s::default(),
            b2: F32s::default(),
            smooth: Mask::splat(false),
            normals: [V3s::default(); 3],
            textured: Mask::splat(false),
            uvs: [(F32s::default(), F32s::default()); 3],
            transformed: Mask::splat(false),
            to_world: [V3s::default(); 4],
            normal_to_world: [V3s::default(); 3],
            given: Mask::splat(false),
            given_normal: V3s::default(),
        }
    }

    /// Puts lane `i` to a hit with barycentrics `(b1, b2)` on the triangle `corners`.
    #[inline]
    pub fn set_corners(&mut self, i: usize, corners: &CornerData, (b1, b2): (f32, f32)) {
        self.given.set(i, false);
        for (lanes, &p) in self.corners.iter_mut().zip(&corners.positions) {
            lanes.set(i, p);
        }
        (self.b1[i], self.b2[i]) = (b1, b2);
        self.smooth.set(i, corners.normals.is_some());
        if let Some(n) = &corners.normals {
            for (lanes, &n) in self.normals.iter_mut().zip(n) {
                lanes.set(i, n);
            }
        }
        self.textured.set(i, corners.uvs.is_some());
        if let Some(uv) = &corners.uvs {
            for (lanes, uv) in self.uvs.iter_mut().zip(uv) {
                (lanes.0[i], lanes.1[i]) = (uv.x, uv.y);
            }
        }
    }

    /// Places lane `i`'s surface by its instance's maps, `None` for an untransformed instance
    /// (as [`Instance::surface`](super::Instance::surface) places it).
    #[inline]
    pub fn set_transform(&mut self, i: usize, maps: Option<(&Affine3A, &Mat3)>) {
        match maps {
            Some(maps) => self.set_maps(i, true, maps),
            None => self.transformed.set(i, false),
        }
    }

    /// Places lane `i`'s surface by the maps `(to_world, normals)` where `transformed`, as
    /// [`set_transform`](Self::set_transform) does, without a branch on `transformed`: the maps
    /// are stored either way (lanes not `transformed` do not apply them).
    #[inline]
    pub fn set_maps(
        &mut self,
        i: usize,
        transformed: bool,
        (to_world, normals): (&Affine3A, &Mat3),
    ) {
        self.transformed.set(i, transformed);
        self.set_to_world(i, to_world);
        for (column, v) in
            self.normal_to_world
                .iter_mut()
                .zip([normals.x_axis, normals.y_axis, normals.z_axis])
        {
            column.set(i, v);
        }
    }

    /// Puts lane `i` to a hit with barycentrics `(b1, b2)` on a flat, untextured triangle at
    /// `positions` whose normal (geometric and shading, in world space) is `normal`
    /// ([`flat_normal`](Self::flat_normal)), placed by `to_world` (`None` for an untransformed
    /// instance): the lane's surface is the one [`set_corners`](Self::set_corners) and
    /// [`set_transform`](Self::set_transform) give, its normals not computed again.
    #[inline]
    pub fn set_flat(
        &mut self,
        i: usize,
        positions: &[Vec3; 3],
        barycentrics: (f32, f32),
        normal: Vec3,
        to_world: Option<&Affine3A>,
    ) {
        let corners = CornerData {
            positions: *positions,
            normals: None,
            uvs: None,
        };
        self.set_corners(i, &corners, barycentrics);
        self.given.set(i, true);
        self.given_normal.set(i, normal);
        self.transformed.set(i, to_world.is_some());
        if let Some(to_world) = to_world {
            self.set_to_world(i, to_world);
        }
    }

    /// [`set_flat`](Self::set_flat) in the `lanes` (bits) of a wave of sixteen at once, from
    /// their triangles' fields in lanes (`fields`, the corners' nine from `positions` on, the
    /// normal's three from `normal` on), with barycentrics `(b1, b2)`; the `transformed` lanes
    /// (bits, of `lanes`) placed by their maps (`maps`: the columns of the linear part, then
    /// the translation; needed only when some lane is transformed).
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    ///
    /// # Panics
    /// Unless W is 16.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub unsafe fn set_flat_rows(
        &mut self,
        lanes: u16,
        (fields, positions, normal): (&[std::arch::x86_64::__m512; 16], usize, usize),
        (b1, b2): (F32s<W>, F32s<W>),
        (transformed, maps): (u16, Option<&[std::arch::x86_64::__m512; 16]>),
    ) {
        use crate::lanes::store_lanes_16 as store;
        let mask = |bits: u16| Mask::<W>::from_bits(u64::from(bits));
        for (c, corner) in self.corners.iter_mut().enumerate() {
            let f = positions + 3 * c;
            store(&mut corner.x, lanes, fields[f]);
            store(&mut corner.y, lanes, fields[f + 1]);
            store(&mut corner.z, lanes, fields[f + 2]);
        }
        let all = mask(lanes);
        self.b1 = F32s::select(all, b1, self.b1);
        self.b2 = F32s::select(all, b2, self.b2);
        self.smooth = self.smooth.and_not(all);
        self.textured = self.textured.and_not(all);
        self.given = self.given | all;
        store(&mut self.given_normal.x, lanes, fields[normal]);
        store(&mut self.given_normal.y, lanes, fields[normal + 1]);
        store(&mut self.given_normal.z, lanes, fields[normal + 2]);
        self.transformed = self.transformed.and_not(all) | mask(transformed);
        if let Some(maps) = maps {
            for (c, column) in self.to_world.iter_mut().enumerate() {
                store(&mut column.x, transformed, maps[3 * c]);
                store(&mut column.y, transformed, maps[3 * c + 1]);
                store(&mut column.z, transformed, maps[3 * c + 2]);
            }
        }
    }

    /// Lane `i`'s object → world map: the columns of the linear part, then the translation.
    #[inline]
    fn set_to_world(&mut self, i: usize, to_world: &Affine3A) {
        let m = &to_world.matrix3;
        for (column, v) in
            self.to_world
                .iter_mut()
                .zip([m.x_axis, m.y_axis, m.z_axis, to_world.translation])
        {
            column.set(i, v.into());
        }
    }

    /// The normal of a hit on a flat triangle at `positions` (object space) placed by `maps`
    /// (`None` for an untransformed instance), as [`run`](Self::run) computes it: the
    /// geometric normal, which for a triangle without vertex normals is the shading normal
    /// too, the same for every point of it.
    pub fn flat_normal(positions: &[Vec3; 3], maps: Option<(&Affine3A, &Mat3)>) -> Vec3 {
        let mut one = SurfaceLanes::<1>::new();
        let corners = CornerData {
            positions: *positions,
            normals: None,
            uvs: None,
        };
        one.set_corners(0, &corners, (0.0, 0.0));
        one.set_transform(0, maps);
        one.run_here().ng.lane(0)
    }

    /// [`Mesh::surface`] in every lane, compiled for the widest vector instructions the CPU
    /// has that suit W lanes (the same operations, so the same bits); `lanes` are those set.
    pub fn run(&self, lanes: Mask<W>) -> SurfacesOut<W> {
        let mut out = SurfacesOut::default();
        self.run_into(lanes, &mut out);
        out
    }

    /// [`run`](Self::run), written into `out` (which a returned value, the size of a few
    /// hundred floats, would be copied into).
    #[inline(always)]
    pub fn run_into(&self, lanes: Mask<W>, out: &mut SurfacesOut<W>) {
        let given_only = !lanes.and_not(self.given).any();
        crate::lanes::widest!(
            W,
            (surfaces: &SurfaceLanes<W>, given_only: bool, out: &mut SurfacesOut<W>) => (),
            (self, given_only, out),
            *out = surfaces.run_with(given_only)
        )
    }

    /// [`run_here`](Self::run_here) with the given normals in their lanes; where `given_only`
    /// (every lane set has them), only the point and the texture coordinates.
    #[inline(always)]
    fn run_with(&self, given_only: bool) -> SurfacesOut<W> {
        if given_only {
            return self.run_given();
        }
        let mut out = self.run_here();
        if self.given.any() {
            out.ng = V3s::select(self.given, self.given_normal, out.ng);
            out.ns = V3s::select(self.given, self.given_normal, out.ns);
        }
        out
    }

    /// The operations of [`run_here`](Self::run_here) for the point and the texture
    /// coordinates, with the given normals.
    #[inline(always)]
    fn run_given(&self) -> SurfacesOut<W> {
        let (p, _) = self.object_point();
        let p = if self.transformed.any() {
            V3s::select(self.transformed, self.placed(p), p)
        } else {
            p
        };
        SurfacesOut {
            p,
            ng: self.given_normal,
            ns: self.given_normal,
            uv: (self.b1, self.b2),
        }
    }

    /// The hit point in object space, a · b0 + b · b1 + c · b2, and b0 = 1 − b1 − b2.
    #[inline(always)]
    fn object_point(&self) -> (V3s<W>, F32s<W>) {
        let [a, b, c] = self.corners;
        let (b1, b2) = (self.b1, self.b2);
        let b0 = 1.0 - b1 - b2;
        (a * b0 + b * b1 + c * b2, b0)
    }

    /// `p` placed by the lanes' object → world maps: glam's `transform_point3`,
    /// ((X·x + Y·y) + Z·z) + T.
    #[inline(always)]
    fn placed(&self, p: V3s<W>) -> V3s<W> {
        let [x, y, z, t] = self.to_world;
        x * p.x + y * p.y + z * p.z + t
    }

    /// The operations of [`Mesh::surface`] and [`interpolate`], in their order.
    #[inline(always)]
    fn run_here(&self) -> SurfacesOut<W> {
        let [a, b, c] = self.corners;
        let (b1, b2) = (self.b1, self.b2);
        let (p, b0) = self.object_point();
        let ng = (b - a).cross(c - a).normalize();
        let [na, nb, nc] = self.normals;
        let s = (na * b0 + nb * b1 + nc * b2).normalize_or_zero();
        let ns = V3s::select(self.smooth & !s.is_zero(), s, ng);
        let [ua, ub, uc] = self.uvs;
        let u = ua.0 * b0 + ub.0 * b1 + uc.0 * b2;
        let v = ua.1 * b0 + ub.1 * b1 + uc.1 * b2;
        let (p, ng, ns) = if self.transformed.any() {
            // `Instance::surface`: the point placed (`placed`), and the normals by the normal
            // map (X·x + Y·y) + Z·z, normalised.
            let placed = self.placed(p);
            // (A function, not a closure: closures do not inherit `widest!`'s target features,
            // so their vector operations would become calls.)
            #[inline(always)]
            fn normal<const W: usize>([x, y, z]: [V3s<W>; 3], n: V3s<W>) -> V3s<W> {
                (x * n.x + y * n.y + z * n.z).normalize()
            }
            let map = self.normal_to_world;
            (
                V3s::select(self.transformed, placed, p),
                V3s::select(self.transformed, normal(map, ng), ng),
                V3s::select(self.transformed, normal(map, ns), ns),
            )
        } else {
            (p, ng, ns)
        };
        SurfacesOut {
            p,
            ng,
            ns,
            uv: (
                F32s::select(self.textured, u, b1),
                F32s::select(self.textured, v, b2),
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::geometry::triangle::{self, RayShear};
    use crate::sampler::test_lcg as lcg;

    #[test]
    fn flat_triangles_given_normals_are_the_computed_ones() {
        // Waves mixing lanes set as flat triangles (normals given) with lanes set by their
        // corners and maps: every lane's surface has the bits of the corners-and-maps one.
        let mut state = 11u64;
        let mut v3 = || Vec3::new(lcg(&mut state), lcg(&mut state), lcg(&mut state)) * 4.0 - 2.0;
        for round in 0..200 {
            let positions: [[Vec3; 3]; 16] = std::array::from_fn(|_| [v3(), v3(), v3()]);
            let maps: [(Affine3A, Mat3); 16] = std::array::from_fn(|_| {
                let (axis, t) = (v3().normalize(), v3());
                let rotation = glam::Quat::from_axis_angle(axis, t.x);
                let m = Affine3A::from_scale_rotation_translation(v3().abs() + 0.1, rotation, t);
                (m, crate::math::inverse(&m.matrix3).transpose().into())
            });
            let mut state = round;
            let mut unit = || lcg(&mut state) * 0.5;
            let barycentrics: [(f32, f32); 16] = std::array::from_fn(|_| (unit(), unit()));
            let (mut want, mut got) = (SurfaceLanes::<16>::new(), SurfaceLanes::<16>::new());
            for i in 0..16 {
                let placed = (i % 3 != 0).then_some((&maps[i].0, &maps[i].1));
                let corners = CornerData {
                    positions: positions[i],
                    normals: None,
                    uvs: None,
                };
                want.set_corners(i, &corners, barycentrics[i]);
                want.set_transform(i, placed);
                // All lanes flat in even rounds, every fourth set by its corners in odd ones.
                if round % 2 == 1 && i % 4 == 1 {
                    got.set_corners(i, &corners, barycentrics[i]);
                    got.set_transform(i, placed);
                } else {
                    let normal = SurfaceLanes::<1>::flat_normal(&positions[i], placed);
                    got.set_flat(
                        i,
                        &positions[i],
                        barycentrics[i],
                        normal,
                        placed.map(|m| m.0),
                    );
                }
            }
            let lanes = Mask::splat(true);
            let (want, got) = (want.run(lanes), got.run(lanes));
            for i in 0..16 {
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!(
                    bits(want.p.lane(i)),
                    bits(got.p.lane(i)),
                    "round {round} lane {i}"
                );
                assert_eq!(
                    bits(want.ng.lane(i)),
                    bits(got.ng.lane(i)),
                    "round {round} lane {i}"
                );
                assert_eq!(
                    bits(want.ns.lane(i)),
                    bits(got.ns.lane(i)),
                    "round {round} lane {i}"
                );
                assert_eq!(want.uv.0[i].to_bits(), got.uv.0[i].to_bits());
                assert_eq!(want.uv.1[i].to_bits(), got.uv.1[i].to_bits());
            }
        }
    }

    #[test]
    fn opacity_inputs_are_those_of_the_full_surface() {
        let mut state = 3u64;
        let mut v3 = || Vec3::new(lcg(&mut state), lcg(&mut state), lcg(&mut state));
        let positions: Vec<Vec3> = (0..30).map(|_| v3() * 4.0 - 2.0).collect();
        let uvs: Vec<Vec2> = positions
            .iter()
            .map(|p| Vec2::new(p.x * 3.1, p.y - p.z))
            .collect();
        let uvs1: Vec<Vec2> = positions
            .iter()
            .map(|p| Vec2::new(p.z, 0.7 * p.x))
            .collect();
        let colors: Vec<Vec4> = positions
            .iter()
            .map(|p| (p.abs() / 2.0).extend(p.x.abs() / 2.0))
            .collect();
        let triangles: Vec<[u32; 3]> = (0..10).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let full = MeshData {
            positions: Arc::new(positions),
            triangles: Arc::new(triangles),
            normals: None,
            uvs: Some(Arc::new(uvs)),
            uvs1: Some(Arc::new(uvs1)),
            tangents: None,
            colors: Some(Arc::new(colors)),
        };
        let bare = MeshData {
            uvs: None,
            uvs1: None,
            colors: None,
            ..full.clone()
        };
        for data in [full, bare] {
            let (mesh, _) = Mesh::new(data);
            for k in 0..1000u32 {
                let (b1, b2) = (lcg(&mut state), lcg(&mut state));
                let (b1, b2) = if b1 + b2 > 1.0 {
                    (1.0 - b1, 1.0 - b2)
                } else {
                    (b1, b2)
                };
                let h = MeshHit {
                    t: 1.0,
                    prim: k % 10,
                    b1,
                    b2,
                };
                let (_, _, _, uv) = mesh.surface(&h);
                let (uv1, _, color) = mesh.attributes(&h);
                let want = OpacityInputs {
                    uv,
                    uv1,
                    color_alpha: color.w,
                };
                // Bit for bit: the alpha test decides like the shading of the same hit.
                assert_eq!(mesh.opacity_inputs(&h), want);
            }
        }
    }

    /// The BVH-accelerated mesh must agree with testing every triangle (the oracle).
    #[test]
    fn bvh_agrees_with_brute_force() {
        let mut s = 3u64;
        let mut positions = Vec::new();
        let mut tris = Vec::new();
        for i in 0..3000u32 {
            let c = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 4.0;
            for _ in 0..3 {
                positions.push(c + Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 0.2);
            }
            tris.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let (mesh, _) = Mesh::from_triangles(positions, tris);
        for _ in 0..3000 {
            let o = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 6.0 - 1.0;
            let d = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            let shear = RayShear::new(o, d);
            let brute = (0..mesh.data.triangles.len() as u32)
                .filter_map(|p| {
                    let [a, b, c] = mesh.corners(p);
                    triangle::intersect(&shear, a, b, c, 0.0, f32::INFINITY).map(|h| (h.t, p))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let fast = mesh
                .intersect(o, d, 0.0, f32::INFINITY)
                .map(|h| (h.t, h.prim));
            assert_eq!(fast.map(|f| f.1), brute.map(|b| b.1));
            assert_eq!(mesh.occluded(o, d, 0.0, f32::INFINITY), brute.is_some());
        }
    }
}
